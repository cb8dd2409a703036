// A pupil's page: GET /api/pupils/{id}/history drawn as facts, two charts (Chart.js, from npm,
// each with its data as a table too), and the sessions and exams.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, dateTime, day, num, pct, param, isStaff } = FL;
  const me = requireLogin();
  const id = param('id') || (me.role === 'pupil' ? String(me.pupil_id) : null);
  const message = document.getElementById('message');
  const charts = {};

  function badge(cls, text) { return el('span', { class: `badge ${cls}` }, text); }
  function passBadge(passed) {
    return passed === null || passed === undefined ? '' : passed ? badge('passed', 'passed') : badge('not-passed', 'not passed');
  }
  // A practical exam whose evidence does not hold counts for nothing: the page says why.
  function evidenceNote(evidence) {
    return evidence && evidence.verified === false ? el('div', { class: 'small warn', 'data-evidence': 'unverified' },
                                                        `Evidence does not verify: ${evidence.problem}`) : '';
  }

  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }

  function latest(exams, kind) {
    const of = exams.filter((e) => e.kind === kind);
    return of.length ? of[of.length - 1] : null;
  }
  function passed(exams, kind) { return exams.some((e) => e.kind === kind && e.passed); }

  function drawCharts(h) {
    const marksCanvas = document.getElementById('marks-chart');
    const labels = h.marks.map((m) => [m.session, dateTime(m.at)]);  // two lines under each point
    const data = h.marks.map((m) => m.mark);
    if (charts.marks) charts.marks.destroy();
    charts.marks = new Chart(marksCanvas, {
      type: 'line',
      data: { labels, datasets: [{ label: 'Mark', data, borderColor: '#0b5cad', backgroundColor: '#0b5cad', pointRadius: 4, tension: 0 }] },
      options: { animation: false, maintainAspectRatio: false, plugins: { legend: { display: false } },
                 scales: { y: { suggestedMin: 0, suggestedMax: 100, title: { display: true, text: 'mark' } },
                           x: { title: { display: true, text: 'session' } } } },
    });
    marksCanvas.setAttribute('aria-label', h.marks.length === 0 ? 'Marks over time: no marked session yet'
      : `Marks over time: ${h.marks.length} marked sessions, the latest ${num(data[data.length - 1])} on ${dateTime(h.marks[h.marks.length - 1].at)}`);
    clear(document.querySelector('#marks-table tbody')).append(...h.marks.map((m) => el('tr', {},
      el('td', {}, el('a', { href: `session.html?id=${encodeURIComponent(m.session)}` }, m.session)),
      el('td', {}, dateTime(m.at)), el('td', { class: 'num' }, num(m.mark)))));

    const faults = Object.entries(h.faults_by_kind).sort((a, b) => b[1] - a[1]);
    const faultsCanvas = document.getElementById('faults-chart');
    if (charts.faults) charts.faults.destroy();
    charts.faults = new Chart(faultsCanvas, {
      type: 'bar',
      data: { labels: faults.map((f) => f[0]), datasets: [{ label: 'Faults', data: faults.map((f) => f[1]), backgroundColor: '#c2410c' }] },
      options: { animation: false, maintainAspectRatio: false, indexAxis: 'y', plugins: { legend: { display: false } },
                 scales: { x: { beginAtZero: true, ticks: { precision: 0 }, title: { display: true, text: 'count' } } } },
    });
    faultsCanvas.setAttribute('aria-label', faults.length === 0 ? 'Faults by kind: none recorded'
      : 'Faults by kind: ' + faults.map(([k, n]) => `${k} ${n}`).join(', '));
    clear(document.querySelector('#faults-table tbody')).append(...faults.map(([k, n]) => el('tr', {},
      el('td', {}, k), el('td', { class: 'num' }, n))));
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
      await api('POST', `/pupils/${encodeURIComponent(id)}/licence`);
      await load();
      say(message, 'Licence issued.', 'ok');
    } catch (e) {
      say(message, describeError(e));
    }
  }

  function actions(h) {
    const box = document.getElementById('staff-actions');
    const q = encodeURIComponent(id);
    const both = passed(h.exams, 'theory') && passed(h.exams, 'practical');
    const items = [];
    if (isStaff(me)) {
      items.push(el('a', { href: `start.html?pupil=${q}` }, 'Start a session'));
      items.push(el('a', { href: `theory.html?pupil=${q}` }, 'Theory exam for this pupil'));
      items.push(el('button', { type: 'button', class: 'secondary', onclick: downloadCsv }, 'Download the history (CSV)'));
      if (both && (me.role === 'admin' || me.role === 'examiner'))
        items.push(el('button', { type: 'button', class: 'secondary', onclick: issueLicence }, h.licence ? 'Issue a new licence' : 'Issue the licence'));
    } else {
      items.push(el('a', { href: 'theory.html' }, 'Take the theory exam'));
    }
    if (both) items.push(el('a', { href: `certificate.html?pupil=${q}`, id: 'certificate-link' }, 'Certification record'));
    clear(box).append(...items);
    box.hidden = false;
  }

  function render(h) {
    const p = h.pupil;
    document.getElementById('name').textContent = p.name;
    document.title = `${p.name} · Forklift school`;
    const dl = clear(document.getElementById('facts'));
    if (p.email) fact(dl, 'Email', p.email);
    fact(dl, 'Pupil since', day(p.created_at));
    fact(dl, 'Sessions', `${h.sessions.length}, of which ${h.marks.length} marked`);
    if (h.trend !== null) fact(dl, 'Trend', `${h.trend >= 0 ? '+' : ''}${num(h.trend, 2)} marks per marked session`);
    const theory = latest(h.exams, 'theory'), practical = latest(h.exams, 'practical');
    fact(dl, 'Theory exam', theory ? [passBadge(theory.passed), ` ${pct(theory.score)} on ${day(theory.taken_at)}`] : 'not taken');
    fact(dl, 'Practical exam', practical ? [passBadge(practical.passed), ` mark ${num(practical.score)} on ${day(practical.taken_at)}`] : 'not taken');
    if (h.licence) {
      fact(dl, 'Licence', `issued ${day(h.licence.issued_at)} by ${h.licence.issued_by}`);
      fact(dl, 'Re-evaluation due', day(h.licence.reevaluation_due), ' ',
           h.reevaluation_overdue ? badge('not-passed', 'overdue') : badge('passed', 'in date'),
           el('span', { class: 'small muted' }, ' (every 3 years, OSHA 1910.178(l)(4)(iii))'));
    } else {
      fact(dl, 'Licence', 'not issued');
    }
    actions(h);
    drawCharts(h);

    clear(document.querySelector('#sessions tbody')).append(...[...h.sessions].reverse().map((s) => el('tr', { 'data-session': s.id },
      el('th', { scope: 'row' }, el('a', { href: `session.html?id=${encodeURIComponent(s.id)}` }, s.id)),
      el('td', {}, dateTime(s.created_at)), el('td', {}, s.scenario), el('td', {}, s.mode), el('td', {}, s.cab_id),
      el('td', {}, badge(s.state, s.state), s.reason ? el('div', { class: 'small muted' }, s.reason) : ''),
      el('td', { class: 'num' }, s.mark === null ? '–' : num(s.mark)), el('td', {}, passBadge(s.passed), evidenceNote(s.evidence)))));
    if (h.sessions.length === 0) document.querySelector('#sessions tbody').append(el('tr', {}, el('td', { colspan: 8, class: 'muted' }, 'No sessions yet.')));

    clear(document.querySelector('#exams tbody')).append(...[...h.exams].reverse().map((e) => el('tr', { 'data-exam': e.id, 'data-kind': e.kind },
      el('th', { scope: 'row' }, e.kind === 'theory' ? 'Theory' : 'Practical'),
      el('td', {}, dateTime(e.taken_at)),
      el('td', {}, e.kind === 'theory' ? `${e.correct ?? '?'} of ${e.total ?? '?'} (${pct(e.score)})` : `mark ${num(e.score)}`),
      el('td', {}, passBadge(e.passed), evidenceNote(e.evidence)),
      el('td', {}, e.kind === 'theory' && e.attempt ? el('a', { href: `theory.html?attempt=${encodeURIComponent(e.attempt)}` }, 'answers')
                 : e.session ? el('a', { href: `session.html?id=${encodeURIComponent(e.session)}` }, e.session) : ''))));
    if (h.exams.length === 0) document.querySelector('#exams tbody').append(el('tr', {}, el('td', { colspan: 5, class: 'muted' }, 'No exams yet.')));
  }

  async function load() {
    if (!id) { say(message, 'Which pupil? Open this page from the pupils list.'); return; }
    try {
      render(await api('GET', `/pupils/${encodeURIComponent(id)}/history`));
    } catch (e) {
      say(message, describeError(e));
    }
  }
  load();
})();
