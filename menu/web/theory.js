// The theory exam. GET /api/theory describes it; GET /api/theory/pupils/{id} says where a pupil
// stands (their papers, and whether they may sit an exam or a practice quiz now, and if not why).
// Staff hand a pupil a supervised exam paper (POST /api/theory/attempts, kind "exam"), which the
// pupil answers on their own login or on the examiner's screen; anyone takes a practice quiz
// (kind "practice"), which never counts. A paper has a time limit that the server keeps: the clock
// here counts down from the server's time left and hands the paper in at zero. The result gives
// the mark, the score by topic and the clauses to read, never the answers. ?attempt=N shows a
// paper again (open or finished); ?pupil=N chooses the pupil for staff.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, pct, dateTime, param, isStaff } = FL;
  const me = requireLogin();
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  let info = null, attempt = null, pupilId = null, standing = null;
  let warnedUnanswered = false, handingIn = false, clockTimer = null;

  function show(section) {
    for (const id of ['intro', 'paper', 'result']) $(id).hidden = id !== section;
  }

  // 125 s -> "2:05"; 3725 s -> "1:02:05".
  function clockText(s) {
    s = Math.max(0, Math.ceil(s));
    const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
    const p = (n) => String(n).padStart(2, '0');
    return h ? `${h}:${p(m)}:${p(sec)}` : `${m}:${p(sec)}`;
  }
  function minutes(s) {
    if (s === null || s === undefined) return '';
    return s % 60 === 0 ? `${s / 60} minute${s === 60 ? '' : 's'}` : `${s} s`;
  }
  function waitWords(s) {
    if (!s) return 'no wait';
    if (s % 86400 === 0) return `${s / 86400} day${s === 86400 ? '' : 's'}`;
    if (s % 3600 === 0) return `${s / 3600} hour${s === 3600 ? '' : 's'}`;
    return minutes(s);
  }

  // ---------------------------------------------------------------- where the pupil stands

  async function loadStanding() {
    clear($('handed-text'));
    $('handed').hidden = true;
    if (!pupilId) {
      $('standing').hidden = true;
      $('papers').hidden = true;
      return;
    }
    standing = await api('GET', `/theory/pupils/${encodeURIComponent(pupilId)}`);
    const ex = standing.exam, pr = standing.practice;
    const open = standing.papers.find((p) => p.outcome === null);
    let text;
    if (ex.allowed) {
      text = isStaff(me) ? 'This pupil may sit a supervised theory exam now.'
                         : 'You may sit the theory exam when an examiner or instructor hands you a paper.';
    } else if (ex.code === 'paper_open' && open && open.kind === 'exam') {
      text = isStaff(me) ? `Exam paper ${open.id} is open until ${dateTime(open.deadline)}.`
                         : `Your exam paper ${open.id} is ready, supervised by ${open.supervised_by}: open it and answer it by ${dateTime(open.deadline)}.`;
    } else {
      text = ex.message;
    }
    $('exam-standing').textContent = text;
    $('exam-standing').dataset.code = ex.code || 'allowed';
    $('open-paper').hidden = !open;
    if (open) $('open-paper').textContent = `Open ${open.kind === 'exam' ? 'exam' : 'practice'} paper ${open.id}`;
    $('begin-exam').hidden = !isStaff(me);
    $('begin-exam').disabled = !ex.allowed;
    $('begin-practice').hidden = false;
    $('begin-practice').disabled = !pr.allowed;
    $('unlock').hidden = !(['admin', 'instructor'].includes(me.role) && ['retake_too_soon', 'retake_locked'].includes(ex.code));
    $('standing').hidden = false;

    const rows = standing.papers.slice().reverse().map((p) => el('tr', { 'data-paper': p.id, 'data-kind': p.kind },
      el('th', { scope: 'row' }, el('a', { href: `theory.html?attempt=${encodeURIComponent(p.id)}` }, `Paper ${p.id}`)),
      el('td', {}, p.kind === 'exam' ? 'Supervised exam' : 'Practice (does not count)'),
      el('td', {}, dateTime(p.started_at)),
      el('td', {}, p.supervised_by || ''),
      el('td', { class: 'outcome' }, p.outcome === null ? (p.deadline ? `open until ${dateTime(p.deadline)}` : 'open')
        : p.outcome === 'timed_out' ? 'timed out' : p.passed ? 'passed' : 'not passed'),
      el('td', { class: 'num' }, p.outcome === 'marked' ? `${p.correct} of ${p.total}` : '')));
    clear($('papers').querySelector('tbody')).append(...rows);
    $('papers').hidden = rows.length === 0;
  }

  async function begin(kind) {
    const body = { kind };
    if (isStaff(me)) body.pupil_id = Number(pupilId);
    try {
      clear(message);
      const a = await api('POST', '/theory/attempts', body);
      if (kind === 'exam' && isStaff(me)) {
        const name = $('pupil').selectedOptions[0] ? $('pupil').selectedOptions[0].textContent : 'the pupil';
        await loadStanding();
        $('handed-text').textContent = `Exam paper ${a.id} is handed out to ${name}, supervised by ${a.supervised_by}: ` +
          `${a.questions.length} questions, ${minutes(a.time_limit_s)}, until ${dateTime(a.deadline)}. ` +
          `${name} answers it from the Theory exam page of their own login, or here on this screen.`;
        $('handed').hidden = false;
        $('answer-here').onclick = () => paper(a);
        return;
      }
      paper(a);
      window.scrollTo(0, 0);
    } catch (e) {
      say(message, describeError(e));
    }
  }

  // ---------------------------------------------------------------- a paper

  function chosen() {
    const answers = {};
    for (const q of attempt.questions) {
      const c = document.querySelector(`input[name="q-${CSS.escape(q.id)}"]:checked`);
      if (c) answers[q.id] = Number(c.value);
    }
    return answers;
  }

  function progress() {
    const n = Object.keys(chosen()).length;
    $('progress').textContent = `${n} of ${attempt.questions.length} answered.`;
  }

  async function picture(box, q) {
    try {
      const blob = await api('GET', q.image.replace(/^\/api/, ''));
      box.append(el('img', { class: 'figure', src: URL.createObjectURL(blob), alt: q.image_alt }));
    } catch (e) {
      box.append(el('p', { class: 'warn' }, `The picture cannot be shown (${describeError(e)}). It shows: ${q.image_alt}`));
    }
  }

  function startClock(a) {
    clearInterval(clockTimer);
    if (a.time_left_s === null) { $('clock').textContent = 'No time limit'; return; }
    // Counted from the server's time left, so that this computer's clock does not matter.
    const end = performance.now() + a.time_left_s * 1000;
    const tick = () => {
      const left = (end - performance.now()) / 1000;
      $('clock').textContent = `Time left ${clockText(left)}`;
      $('clock').dataset.left = String(Math.max(0, Math.round(left)));
      if (left <= 0) {
        clearInterval(clockTimer);
        handIn(true);
      }
    };
    tick();
    clockTimer = setInterval(tick, 500);
  }

  function paper(a) {
    attempt = a;
    warnedUnanswered = false;
    handingIn = false;
    $('hand-in').disabled = false;
    $('paper-kind').textContent = a.kind === 'exam'
      ? `Supervised theory exam, handed out by ${a.supervised_by}. It counts toward the theory exam and the certificate.`
      : 'Practice quiz: it is marked, but it does not count toward the theory exam or the certificate.';
    $('paper-kind').dataset.kind = a.kind;
    $('paper-intro').textContent = `${a.questions.length} questions, ${minutes(a.time_limit_s)} to answer them` +
      (a.deadline ? ` (until ${dateTime(a.deadline)})` : '') + `. Choose one answer to each; you pass with ${pct(a.pass_mark)} right. ` +
      'Nothing is marked until you hand in; when the time is up the paper is handed in as it stands, and answers after that are not marked.';
    const box = clear($('questions'));
    a.questions.forEach((q, i) => {
      const name = `q-${q.id}`;
      const fieldset = el('fieldset', { class: 'question', 'data-question': q.id },
        el('legend', {}, `${i + 1}. ${q.text}`),
        el('p', { class: 'topic' }, `Question ${i + 1} of ${a.questions.length} · ${q.topic_title}`));
      if (q.image) {
        const figure = el('div', { class: 'picture' });
        fieldset.append(figure);
        picture(figure, q);
      }
      fieldset.append(...q.choices.map((c, k) => el('label', { class: 'choice', for: `${name}-${k}` },
        el('input', { type: 'radio', name, id: `${name}-${k}`, value: k, onchange: progress }), c)));
      box.append(fieldset);
    });
    progress();
    show('paper');
    startClock(a);
    history.replaceState(null, '', `theory.html?attempt=${encodeURIComponent(a.id)}`);
  }

  async function handIn(timeUp) {
    if (handingIn) return;
    const answers = chosen();
    const missing = attempt.questions.length - Object.keys(answers).length;
    if (!timeUp && missing > 0 && !warnedUnanswered) {
      warnedUnanswered = true;
      say(message, `${missing} question${missing === 1 ? ' is' : 's are'} not answered and will count as wrong. Press "Hand in" again to hand in anyway.`, 'warn');
      return;
    }
    handingIn = true;
    $('hand-in').disabled = true;
    clearInterval(clockTimer);
    try {
      const a = await api('POST', `/theory/attempts/${encodeURIComponent(attempt.id)}/answers`, { answers });
      clear(message);
      result(a);
      window.scrollTo(0, 0);
    } catch (e) {
      if (e.code === 'timed_out') {
        // The server's clock ended the paper: show it as the server recorded it.
        result(await api('GET', `/theory/attempts/${encodeURIComponent(attempt.id)}`));
        say(message, describeError(e), 'warn');
        return;
      }
      say(message, describeError(e));
      handingIn = false;
      $('hand-in').disabled = false;
      startClock(await api('GET', `/theory/attempts/${encodeURIComponent(attempt.id)}`));
    }
  }

  $('paper').addEventListener('submit', (ev) => {
    ev.preventDefault();
    handIn(false);
  });

  // ---------------------------------------------------------------- a result

  function result(a) {
    clearInterval(clockTimer);
    const r = a.result;
    const timedOut = r.outcome === 'timed_out';
    const summary = clear($('result-summary'));
    summary.append(
      el('p', { class: timedOut || !r.passed ? 'error' : 'ok', id: 'verdict' },
         timedOut ? 'Timed out.' : r.passed ? 'Passed.' : 'Not passed.'),
      a.kind === 'practice' ? el('p', { class: 'warn', id: 'practice-result' }, 'Practice quiz: this result does not count toward the theory exam or the certificate.') : '',
      timedOut
        ? el('p', {}, `The time ran out at ${dateTime(a.deadline)} before the paper was handed in, so nothing on it was marked.`)
        : el('p', {}, `${r.correct} of ${r.total} right: ${pct(r.score)}; the pass mark is ${pct(r.pass_mark)}.`),
      el('p', { class: 'muted', id: 'stored' },
         r.exam_id ? `Recorded as theory exam ${r.exam_id} on ${dateTime(r.taken_at)}` : `Practice paper ${a.id}, ${dateTime(r.taken_at)}`,
         r.supervised_by ? `, supervised by ${r.supervised_by}` : '', r.handed_in_by ? `, handed in by ${r.handed_in_by}` : '', '.'));
    // In the bank's order of topics, as the intro lists them.
    const order = info ? info.topics.map((x) => x.id) : [];
    const rank = (t) => (order.indexOf(t) + 1) || order.length + 1;
    const topics = Object.entries(r.by_topic).sort(([a], [b]) => rank(a) - rank(b));
    clear($('by-topic').querySelector('tbody')).append(...topics.map(([t, v]) => {
      const title = (info && info.topics.find((x) => x.id === t) || { title: t }).title;
      return el('tr', { 'data-topic': t }, el('th', { scope: 'row' }, title), el('td', { class: 'num' }, `${v.correct} of ${v.total}`));
    }));
    $('by-topic').hidden = Object.keys(r.by_topic).length === 0;
    const list = clear($('to-revise'));
    if (r.to_revise.length === 0) {
      list.append(el('li', {}, timedOut ? 'Nothing was marked: go over every topic before the next paper.' : 'Nothing: every answer was right.'));
    }
    for (const t of r.to_revise) {
      list.append(el('li', { 'data-topic': t.topic },
        el('strong', {}, t.title), `: ${t.missed} question${t.missed === 1 ? '' : 's'} missed. Read ${t.clauses.join('; ')}.`));
    }
    show('result');
    history.replaceState(null, '', `theory.html?attempt=${encodeURIComponent(a.id)}`);
  }

  // ---------------------------------------------------------------- the page

  $('begin-exam').addEventListener('click', () => begin('exam'));
  $('begin-practice').addEventListener('click', () => begin('practice'));
  $('open-paper').addEventListener('click', async () => {
    const open = standing && standing.papers.find((p) => p.outcome === null);
    if (!open) return;
    try {
      const a = await api('GET', `/theory/attempts/${encodeURIComponent(open.id)}`);
      if (a.finished) result(a); else paper(a);
    } catch (e) {
      say(message, describeError(e));
    }
  });
  $('unlock').addEventListener('click', async () => {
    try {
      await api('POST', `/theory/pupils/${encodeURIComponent(pupilId)}/unlock`, { reason: 'unlocked on the theory exam page' });
      await loadStanding();
      say(message, 'Unlocked: the pupil may sit another supervised exam now.', 'ok');
    } catch (e) {
      say(message, describeError(e));
    }
  });
  $('pupil').addEventListener('change', async () => {
    pupilId = $('pupil').value || null;
    try { await loadStanding(); } catch (e) { say(message, describeError(e)); }
  });

  async function init() {
    try {
      info = await api('GET', '/theory');
      const id = param('attempt');
      if (id) {
        const a = await api('GET', `/theory/attempts/${encodeURIComponent(id)}`);
        if (a.finished) result(a); else paper(a);
        return;
      }
      const p = info.policy;
      $('intro-text').textContent = `A theory exam paper has ${info.questions_per_exam} multiple-choice questions drawn for you from a bank of ` +
        `${info.questions_in_bank}, covering every topic below, with ${minutes(p.exam_time_limit_s)} to answer them. ` +
        `The server marks it; you pass with ${pct(info.pass_mark)} right, and the result is stored on your record.`;
      $('rules-text').textContent = 'An exam is sat under supervision: an examiner or instructor hands out the paper. ' +
        `After a paper that does not pass, the next may be sat after ${waitWords(p.retake_wait_s)}` +
        (p.max_attempts ? `; after ${p.max_attempts} papers without a pass an instructor must unlock further attempts` : '') +
        `. A practice quiz of ${p.practice_questions} questions in ${minutes(p.practice_time_limit_s)} may be taken at any time and never counts.`;
      $('pass-why').textContent = info.pass_mark_why;
      clear($('topics').querySelector('tbody')).append(...info.topics.map((t) => el('tr', {},
        el('th', { scope: 'row' }, t.title), el('td', {}, t.osha), el('td', { class: 'num' }, t.questions))));
      if (isStaff(me)) {
        const pupils = (await api('GET', '/pupils?limit=1000')).pupils;
        const want = param('pupil');
        // The one asked for, if the first thousand by name do not have them.
        if (want && !pupils.some((x) => String(x.id) === want)) pupils.unshift(await api('GET', `/pupils/${encodeURIComponent(want)}`));
        $('pupil').append(el('option', { value: '' }, 'choose a pupil'),
          ...pupils.map((x) => el('option', { value: x.id, selected: String(x.id) === want }, x.name)));
        $('for-pupil').hidden = false;
        pupilId = $('pupil').value || null;
      } else {
        pupilId = me.pupil_id;
      }
      await loadStanding();
      show('intro');
    } catch (e) {
      say(message, describeError(e));
    }
  }
  init();
})();
