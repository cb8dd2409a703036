// A pupil's page: GET /api/pupils/{id}/history drawn as facts, two charts (Chart.js, from npm,
// each with its data as a table too), the training sessions, and the exams with their corrections.
// Marks are the server's: only a session that ran its course has one (the API's "marks"); the
// others ("unmarked": aborted, timed out, stopped, failed) are listed with their outcome, never
// drawn. Training marks and exam marks are two series.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, dateTime, day, num, pct, param, isStaff, outcomeText, reasonText, t } = FL;
  const me = requireLogin();
  const id = param('id') || (me.role === 'pupil' ? String(me.pupil_id) : null);
  const message = document.getElementById('message');
  const charts = {};

  function badge(cls, text) { return el('span', { class: `badge ${cls}` }, text); }
  function passBadge(passed) {
    return passed === null || passed === undefined ? '' : passed ? badge('passed', t('passed')) : badge('not-passed', t('not_passed'));
  }
  function outcomeBadge(o) { return badge(o === 'completed' ? 'ended' : o === 'open' ? 'running' : o === 'failed' || o === 'timed_out' ? 'failed' : 'aborted', outcomeText(o)); }
  // Why a result is not a pass, in the server's words.
  function reasonsList(reasons) {
    return reasons && reasons.length ? el('ul', { class: 'small reasons' }, reasons.map((r) => el('li', { 'data-code': r.code }, FL.reasonWords(r)))) : '';
  }

  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }

  function latest(exams, kind) {
    const of = exams.filter((e) => e.kind === kind && e.id !== null);
    return of.length ? of[of.length - 1] : null;
  }
  const counted = (exams, kind) => exams.some((e) => e.kind === kind && e.counts_toward_licence);

  function drawCharts(h) {
    const marksCanvas = document.getElementById('marks-chart');
    // One label per marked session in time order; each series has its marks and gaps elsewhere.
    const labels = h.marks.map((m) => [m.session, dateTime(m.at)]);
    const series = (mode) => h.marks.map((m) => (m.mode === mode ? m.mark : null));
    if (charts.marks) charts.marks.destroy();
    charts.marks = new Chart(marksCanvas, {
      type: 'line',
      data: { labels, datasets: [
        { label: t('pupil.series_training'), data: series('training'), borderColor: '#0b5cad', backgroundColor: '#0b5cad', pointRadius: 4, tension: 0, spanGaps: true },
        { label: t('pupil.series_exam'), data: series('exam'), borderColor: '#c2410c', backgroundColor: '#c2410c', pointRadius: 6,
          pointStyle: 'rectRot', showLine: false },
      ] },
      options: { animation: false, maintainAspectRatio: false, plugins: { legend: { display: true } },
                 scales: { y: { suggestedMin: 0, suggestedMax: 100, title: { display: true, text: t('pupil.axis_mark') } },
                           x: { title: { display: true, text: t('pupil.axis_session') } } } },
    });
    const training = h.marks.filter((m) => m.mode === 'training'), exams = h.marks.filter((m) => m.mode === 'exam');
    marksCanvas.setAttribute('aria-label', h.marks.length === 0 ? t('pupil.marks_none')
      : t('pupil.marks_label', { training: training.length, exams: exams.length, mark: num(h.marks[h.marks.length - 1].mark),
                                 at: dateTime(h.marks[h.marks.length - 1].at) }) +
        (h.unmarked.length ? t('pupil.marks_unmarked', { count: h.unmarked.length }) : ''));
    clear(document.querySelector('#marks-table tbody')).append(...h.marks.map((m) => el('tr', { 'data-session': m.session },
      el('td', {}, el('a', { href: `session.html?id=${encodeURIComponent(m.session)}` }, m.session)),
      el('td', {}, dateTime(m.at)), el('td', {}, t(m.mode === 'exam' ? 'pupil.practical_exam' : 'pupil.training_lower')), el('td', { class: 'num' }, num(m.mark)))));
    document.getElementById('unmarked-box').hidden = h.unmarked.length === 0;
    clear(document.querySelector('#unmarked tbody')).append(...h.unmarked.map((u) => el('tr', { 'data-session': u.session, 'data-outcome': u.outcome },
      el('td', {}, el('a', { href: `session.html?id=${encodeURIComponent(u.session)}` }, u.session)),
      el('td', {}, dateTime(u.at)), el('td', {}, t(u.mode === 'exam' ? 'pupil.practical_exam' : 'pupil.training_lower')),
      el('td', {}, outcomeBadge(u.outcome), u.reason ? el('span', { class: 'small muted' }, ` (${reasonText(u.reason)})`) : ''))));

    // Words, not the rule's code: the catalogue's title, else the server's.
    const title = (k) => (FL.has(`words:rules.${k}.title`) ? t(`words:rules.${k}.title`) : (h.fault_titles || {})[k] || k.replace(/_/g, ' '));
    const faults = Object.entries(h.faults_by_kind).sort((a, b) => b[1] - a[1]);
    const faultsCanvas = document.getElementById('faults-chart');
    if (charts.faults) charts.faults.destroy();
    charts.faults = new Chart(faultsCanvas, {
      type: 'bar',
      data: { labels: faults.map((f) => title(f[0])), datasets: [{ label: t('pupil.faults'), data: faults.map((f) => f[1]), backgroundColor: '#c2410c' }] },
      options: { animation: false, maintainAspectRatio: false, indexAxis: 'y', plugins: { legend: { display: false } },
                 scales: { x: { beginAtZero: true, ticks: { precision: 0 }, title: { display: true, text: t('pupil.axis_count') } } } },
    });
    faultsCanvas.setAttribute('aria-label', faults.length === 0 ? t('pupil.faults_none')
      : t('pupil.faults_label', { list: faults.map(([k, n]) => `${title(k)} ${n}`).join(', ') }));
    clear(document.querySelector('#faults-table tbody')).append(...faults.map(([k, n]) => el('tr', {},
      el('td', { 'data-kind': k }, title(k)), el('td', { class: 'num' }, n))));
  }

  async function downloadCsv() {
    try {
      const blob = await api('GET', `/pupils/${encodeURIComponent(id)}/history.csv`);
      const a = el('a', { href: URL.createObjectURL(blob), download: `pupil-${id}-history.csv` });
      document.body.append(a);
      a.click();
      a.remove();
    } catch (e) {
      say(message, describeError(e));
    }
  }

  async function issueLicence() {
    try {
      // The certificate's language: the pupil's unless the examiner chooses another.
      const language = document.getElementById('certificate-language').value;
      const l = await api('POST', `/pupils/${encodeURIComponent(id)}/licence`, language ? { language } : undefined);
      await load();
      say(message, t('pupil.licence_issued', { number: l.certificate }), 'ok');
    } catch (e) {
      say(message, describeError(e));
    }
  }

  function actions(h) {
    const box = document.getElementById('staff-actions');
    const q = encodeURIComponent(id);
    const both = counted(h.exams, 'theory') && counted(h.exams, 'practical');
    const items = [];
    if (isStaff(me)) {
      items.push(el('a', { href: `start.html?pupil=${q}` }, t('pupil.start')));
      items.push(el('a', { href: `theory.html?pupil=${q}` }, t('pupil.theory_for')));
      items.push(el('button', { type: 'button', class: 'secondary', onclick: downloadCsv }, t('pupil.csv')));
      if (both && (me.role === 'admin' || me.role === 'examiner'))
        items.push(el('button', { type: 'button', class: 'secondary', id: 'issue-licence', onclick: issueLicence },
                      t(h.licence ? 'pupil.issue_new' : 'pupil.issue')),
                   // Each language named in itself, as a reader of it looks for it.
                   el('span', {}, el('label', { for: 'certificate-language' }, t('pupil.certificate_in')),
                      el('select', { id: 'certificate-language' }, el('option', { value: '' }, t('pupil.pupils_language')),
                         el('option', { value: 'en', lang: 'en' }, 'English'), el('option', { value: 'es', lang: 'es' }, 'Español'))));
    } else {
      items.push(el('a', { href: 'theory.html' }, t('pupil.take_theory')));
    }
    // The certificate is made with the licence: none to print before it is issued.
    if (h.licence) items.push(el('a', { href: `certificate.html?pupil=${q}`, id: 'certificate-link' }, t('pupil.certificate')));
    clear(box).append(...items);
    box.hidden = false;
  }

  // A session's debrief notes, as its session page keeps them: who, when, and the text as typed.
  function notesList(notes) {
    if (!notes || notes.length === 0) return el('span', { class: 'muted' }, t('none'));
    return el('ul', { class: 'notes' }, ...notes.map((n) => el('li', { 'data-note': n.id },
      el('div', { class: 'small muted' }, `${n.author?.name || n.author?.username || t('pupil.someone')}, ${dateTime(n.at)}`), n.text)));
  }

  // A correction, by an examiner or an administrator: a new record beside the exam, with its reason.
  function correctionForm(e) {
    const reason = el('input', { type: 'text', name: 'reason', required: true, maxlength: 1000, 'aria-label': t('pupil.reason') });
    const passed = el('select', { name: 'passed', 'aria-label': t('pupil.result') },
      el('option', { value: '' }, t('pupil.result_unchanged')), el('option', { value: 'false' }, t('pupil.withdraw')),
      el('option', { value: 'true' }, t('passed')));
    const note = el('input', { type: 'text', name: 'note', maxlength: 1000, 'aria-label': t('pupil.note') });
    const form = el('form', { class: 'correction-form', 'data-exam': e.id },
      el('label', {}, t('pupil.reason'), reason), el('label', {}, t('pupil.result'), passed), el('label', {}, t('pupil.note'), note),
      el('button', { type: 'submit', class: 'secondary' }, t('pupil.record_correction')));
    form.addEventListener('submit', async (ev) => {
      ev.preventDefault();
      const body = { reason: reason.value };
      if (passed.value) body.passed = passed.value === 'true';
      if (note.value) body.note = note.value;
      try {
        await api('POST', `/exams/${e.id}/corrections`, body);
        await load();
        say(message, t('pupil.correction_done', { id: e.id }), 'ok');
      } catch (x) {
        say(message, describeError(x));
      }
    });
    return el('details', { class: 'no-print' }, el('summary', {}, t('pupil.correct')), form);
  }

  function correctionsList(e) {
    if (!e.corrections || e.corrections.length === 0) return '';
    return el('ul', { class: 'small corrections' }, e.corrections.map((c) => el('li', { 'data-correction': c.id },
      t('pupil.correction', { id: c.id, at: dateTime(c.at), by: c.by_name || c.by }),
      Object.entries(c.correction || {}).map(([k, v]) => `${FL.has(`pupil.field.${k}`) ? t(`pupil.field.${k}`) : k} ${typeof v === 'boolean' ? t(v ? 'pupil.yes' : 'pupil.no') : v}`).join(', '),
      ` (${c.reason})`)));
  }

  function examRow(e) {
    const score = e.score === null ? el('span', { class: 'muted' }, t('pupil.no_mark'))
      : e.kind === 'theory' ? t('pupil.of', { correct: e.correct ?? '?', total: e.total ?? '?', pct: pct(e.score) }) : t('pupil.mark_n', { mark: num(e.score) });
    const counts = e.kind === 'practical' && e.passed
      ? el('div', { class: 'small' }, e.counts_toward_licence ? t('pupil.counts') : FL.tAround('pupil.not_counted', 'why', FL.english(e.not_counted))) : '';
    const detailsCell = e.kind === 'theory' && e.attempt ? el('a', { href: `theory.html?attempt=${encodeURIComponent(e.attempt)}` }, t('pupil.answers'))
      : e.session ? [el('a', { href: `session.html?id=${encodeURIComponent(e.session)}` }, e.session),
                     e.exam_course ? el('div', { class: 'small' }, FL.has(`words:scenarios.${e.scenario}`) ? t(`words:scenarios.${e.scenario}`) : FL.english(e.exam_course)) : e.scenario ? el('div', { class: 'small muted' }, e.scenario) : ''] : '';
    return el('tr', { 'data-exam': e.id === null ? '' : e.id, 'data-kind': e.kind, 'data-outcome': e.outcome },
      el('th', { scope: 'row' }, t(e.kind === 'theory' ? 'pupil.theory' : 'pupil.practical'), e.id === null ? '' : el('div', { class: 'small muted' }, t('pupil.exam_n', { id: e.id }))),
      el('td', {}, dateTime(e.taken_at)),
      el('td', {}, outcomeBadge(e.outcome)),
      el('td', {}, score),
      el('td', {}, passBadge(e.passed), reasonsList(e.passed ? [] : e.reasons), counts, correctionsList(e),
         e.id !== null && (me.role === 'admin' || me.role === 'examiner') ? correctionForm(e) : ''),
      el('td', {}, e.examiner_name || e.examiner || ''),
      el('td', {}, detailsCell));
  }

  function render(h) {
    const p = h.pupil;
    document.getElementById('name').textContent = p.name;
    document.title = t('title', { page: p.name });
    const dl = clear(document.getElementById('facts'));
    if (p.email) fact(dl, t('pupil.email'), p.email);
    fact(dl, t('pupil.since'), day(p.created_at));
    const training = h.sessions.filter((s) => s.mode === 'training');
    const marked = h.marks.filter((m) => m.mode === 'training').length;
    fact(dl, t('pupil.training_sessions'), t('pupil.marked', { count: training.length, marked }));
    if (h.trend !== null) fact(dl, t('pupil.trend'), t('pupil.trend_value', { trend: `${h.trend >= 0 ? '+' : ''}${num(h.trend, 2)}` }));
    const theory = latest(h.exams, 'theory'), practical = latest(h.exams, 'practical');
    fact(dl, t('pupil.theory_exam'), theory ? [passBadge(theory.passed), ` ${pct(theory.score)}`, t('pupil.on', { day: day(theory.taken_at) })] : t('pupil.not_taken'));
    fact(dl, t('pupil.practical_exam_fact'), practical ? [passBadge(practical.passed),
    ` ${practical.score === null ? outcomeText(practical.outcome) : t('pupil.mark_n', { mark: num(practical.score) })}`,
    t('pupil.on', { day: day(practical.taken_at) })] : t('pupil.not_taken'));
    if (h.licence) {
      fact(dl, t('pupil.licence'), t('pupil.licence_value', { day: day(h.licence.issued_at), by: h.licence.issued_by }));
      fact(dl, t('pupil.reevaluation'), day(h.licence.reevaluation_due), ' ',
           h.reevaluation_overdue ? badge('not-passed', t('pupil.overdue')) : badge('passed', t('pupil.in_date')),
           el('span', { class: 'small muted' }, t('pupil.every_3_years')));
    } else {
      fact(dl, t('pupil.licence'), t('pupil.not_issued'));
    }
    actions(h);
    drawCharts(h);

    const tbody = clear(document.querySelector('#sessions tbody'));
    tbody.append(...[...training].reverse().map((s) => el('tr', { 'data-session': s.id, 'data-outcome': s.outcome },
      el('th', { scope: 'row' }, el('a', { href: `session.html?id=${encodeURIComponent(s.id)}` }, s.id)),
      el('td', {}, dateTime(s.created_at)), el('td', {}, s.scenario), el('td', {}, s.cab_id),
      el('td', {}, outcomeBadge(s.outcome), s.reason ? el('div', { class: 'small muted' }, reasonText(s.reason)) : ''),
      el('td', { class: 'num' }, s.mark === null ? el('span', { class: 'muted' }, t('pupil.no_mark')) : num(s.mark)),
      el('td', {}, passBadge(s.passed)), el('td', { class: 'notes' }, notesList(s.notes)))));
    if (training.length === 0) tbody.append(el('tr', {}, el('td', { colspan: 8, class: 'muted' }, t('pupil.no_training'))));

    const exams = clear(document.querySelector('#exams tbody'));
    exams.append(...[...h.exams].reverse().map(examRow));
    if (h.exams.length === 0) exams.append(el('tr', {}, el('td', { colspan: 7, class: 'muted' }, t('pupil.no_exams'))));
  }

  async function load() {
    if (!id) { say(message, t('pupil.which')); return; }
    try {
      render(await api('GET', `/pupils/${encodeURIComponent(id)}/history`));
    } catch (e) {
      say(message, describeError(e));
    }
  }
  FL.wordPage('pupil.title').then(load);
})();
