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
  const { api, el, clear, requireLogin, say, describeError, pct, dateTime, param, isStaff, t } = FL;
  const me = requireLogin();
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  let info = null, attempt = null, pupilId = null, standing = null;
  let warnedUnanswered = false, handingIn = false, clockTimer = null;

  function show(section) {
    for (const id of ['intro', 'paper', 'result']) $(id).hidden = id !== section;
  }

  // A topic's title in the page's language (the bank's own, in English, where the catalogue has none).
  const topicTitle = (id, english) => (FL.has(`theory.topic.${id}`) ? t(`theory.topic.${id}`) : english);

  // 125 s -> "2:05"; 3725 s -> "1:02:05".
  function clockText(s) {
    s = Math.max(0, Math.ceil(s));
    const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
    const p = (n) => String(n).padStart(2, '0');
    return h ? `${h}:${p(m)}:${p(sec)}` : `${m}:${p(sec)}`;
  }
  function minutes(s) {
    if (s === null || s === undefined) return '';
    return s % 60 === 0 ? t('theory.minutes', { count: s / 60 }) : t('theory.seconds', { count: s });
  }
  function waitWords(s) {
    if (!s) return t('theory.no_wait');
    if (s % 86400 === 0) return t('theory.days', { count: s / 86400 });
    if (s % 3600 === 0) return t('theory.hours', { count: s / 3600 });
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
      text = t(isStaff(me) ? 'theory.staff_may' : 'theory.pupil_may');
    } else if (ex.code === 'paper_open' && open && open.kind === 'exam') {
      text = t(isStaff(me) ? 'theory.staff_open' : 'theory.pupil_open', { id: open.id, by: open.supervised_by, deadline: dateTime(open.deadline) });
    } else {
      text = ex.message;
    }
    $('exam-standing').textContent = text;
    $('exam-standing').dataset.code = ex.code || 'allowed';
    $('open-paper').hidden = !open;
    if (open) $('open-paper').textContent = t(open.kind === 'exam' ? 'theory.open_exam' : 'theory.open_practice', { id: open.id });
    $('begin-exam').hidden = !isStaff(me);
    $('begin-exam').disabled = !ex.allowed;
    $('begin-practice').hidden = false;
    $('begin-practice').disabled = !pr.allowed;
    $('unlock').hidden = !(['admin', 'instructor'].includes(me.role) && ['retake_too_soon', 'retake_locked'].includes(ex.code));
    $('standing').hidden = false;

    const rows = standing.papers.slice().reverse().map((p) => el('tr', { 'data-paper': p.id, 'data-kind': p.kind },
      el('th', { scope: 'row' }, el('a', { href: `theory.html?attempt=${encodeURIComponent(p.id)}` }, t('theory.paper_n', { id: p.id }))),
      el('td', {}, t(p.kind === 'exam' ? 'theory.supervised_exam' : 'theory.practice_kind')),
      el('td', {}, dateTime(p.started_at)),
      el('td', {}, p.supervised_by || ''),
      el('td', { class: 'outcome' }, p.outcome === null ? (p.deadline ? t('theory.open_until', { deadline: dateTime(p.deadline) }) : t('theory.open'))
        : t(p.outcome === 'timed_out' ? 'theory.timed_out' : p.passed ? 'passed' : 'not_passed')),
      el('td', { class: 'num' }, p.outcome === 'marked' ? t('theory.of', { correct: p.correct, total: p.total }) : '')));
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
        const name = $('pupil').selectedOptions[0] ? $('pupil').selectedOptions[0].textContent : t('theory.the_pupil');
        await loadStanding();
        $('handed-text').textContent = t('theory.handed', { id: a.id, name, by: a.supervised_by, questions: a.questions.length,
                                                            time: minutes(a.time_limit_s), deadline: dateTime(a.deadline) });
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
    $('progress').textContent = t('theory.answered', { count: n, total: attempt.questions.length });
  }

  async function picture(box, q) {
    try {
      const blob = await api('GET', q.image.replace(/^\/api/, ''));
      box.append(el('img', { class: 'figure', src: URL.createObjectURL(blob), alt: q.image_alt }));
    } catch (e) {
      box.append(el('p', { class: 'warn' }, ...FL.tAround('theory.no_picture', 'why', describeError(e), { alt: q.image_alt })));
    }
  }

  function startClock(a) {
    clearInterval(clockTimer);
    if (a.time_left_s === null) { $('clock').textContent = t('theory.no_limit'); return; }
    // Counted from the server's time left, so that this computer's clock does not matter.
    const end = performance.now() + a.time_left_s * 1000;
    const tick = () => {
      const left = (end - performance.now()) / 1000;
      $('clock').textContent = t('theory.time_left', { left: clockText(left) });
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
    $('paper-kind').textContent = t(a.kind === 'exam' ? 'theory.exam_kind' : 'theory.practice_paper', { by: a.supervised_by });
    $('paper-kind').dataset.kind = a.kind;
    $('paper-intro').textContent = t('theory.intro', { questions: a.questions.length, time: minutes(a.time_limit_s) }) +
      (a.deadline ? t('theory.until', { deadline: dateTime(a.deadline) }) : '') + t('theory.intro_rest', { pass: pct(a.pass_mark) });
    const box = clear($('questions'));
    a.questions.forEach((q, i) => {
      const name = `q-${q.id}`;
      const fieldset = el('fieldset', { class: 'question', 'data-question': q.id },
        el('legend', {}, `${i + 1}. `, FL.english(q.text)),
        el('p', { class: 'topic' }, t('theory.question_of', { n: i + 1, total: a.questions.length, topic: topicTitle(q.topic, q.topic_title) })));
      if (q.image) {
        const figure = el('div', { class: 'picture' });
        fieldset.append(figure);
        picture(figure, q);
      }
      fieldset.append(...q.choices.map((c, k) => el('label', { class: 'choice', for: `${name}-${k}` },
        el('input', { type: 'radio', name, id: `${name}-${k}`, value: k, onchange: progress }), FL.english(c))));
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
      say(message, t('theory.unanswered', { count: missing }), 'warn');
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
         t(timedOut ? 'theory.verdict_timed_out' : r.passed ? 'theory.verdict_passed' : 'theory.verdict_not_passed')),
      a.kind === 'practice' ? el('p', { class: 'warn', id: 'practice-result' }, t('theory.practice_result')) : '',
      timedOut
        ? el('p', {}, t('theory.ran_out', { deadline: dateTime(a.deadline) }))
        : el('p', {}, t('theory.score', { correct: r.correct, total: r.total, score: pct(r.score), pass: pct(r.pass_mark) })),
      el('p', { class: 'muted', id: 'stored' },
         r.exam_id ? t('theory.recorded', { id: r.exam_id, at: dateTime(r.taken_at) }) : t('theory.practice_n', { id: a.id, at: dateTime(r.taken_at) }),
         r.supervised_by ? t('theory.supervised', { by: r.supervised_by }) : '', r.handed_in_by ? t('theory.handed_in_by', { by: r.handed_in_by }) : '', '.'));
    // In the bank's order of topics, as the intro lists them.
    const order = info ? info.topics.map((x) => x.id) : [];
    const rank = (topic) => (order.indexOf(topic) + 1) || order.length + 1;
    const topics = Object.entries(r.by_topic).sort(([a], [b]) => rank(a) - rank(b));
    clear($('by-topic').querySelector('tbody')).append(...topics.map(([topic, v]) => {
      const title = topicTitle(topic, (info && info.topics.find((x) => x.id === topic) || { title: topic }).title);
      return el('tr', { 'data-topic': topic }, el('th', { scope: 'row' }, title), el('td', { class: 'num' }, t('theory.of', { correct: v.correct, total: v.total })));
    }));
    $('by-topic').hidden = Object.keys(r.by_topic).length === 0;
    const list = clear($('to-revise'));
    if (r.to_revise.length === 0) {
      list.append(el('li', {}, t(timedOut ? 'theory.nothing_marked' : 'theory.nothing')));
    }
    for (const x of r.to_revise) {
      list.append(el('li', { 'data-topic': x.topic },
        el('strong', {}, topicTitle(x.topic, x.title)), t('theory.missed', { count: x.missed, clauses: x.clauses.join('; ') })));
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
      say(message, t('theory.unlocked'), 'ok');
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
      $('intro-text').textContent = t('theory.intro_text', { questions: info.questions_per_exam, bank: info.questions_in_bank,
                                                             time: minutes(p.exam_time_limit_s), pass: pct(info.pass_mark) });
      $('rules-text').textContent = t('theory.rules_text', { wait: waitWords(p.retake_wait_s) }) +
        (p.max_attempts ? t('theory.rules_max', { count: p.max_attempts }) : '') +
        t('theory.rules_practice', { questions: p.practice_questions, time: minutes(p.practice_time_limit_s) });
      // The bank's reason in English; the catalogue's in another language.
      $('pass-why').textContent = document.documentElement.lang === 'en' ? info.pass_mark_why : t('theory.pass_mark_why');
      clear($('topics').querySelector('tbody')).append(...info.topics.map((x) => el('tr', {},
        el('th', { scope: 'row' }, topicTitle(x.id, x.title)), el('td', {}, x.osha), el('td', { class: 'num' }, x.questions))));
      if (isStaff(me)) {
        const pupils = (await api('GET', '/pupils?limit=1000')).pupils;
        const want = param('pupil');
        // The one asked for, if the first thousand by name do not have them.
        if (want && !pupils.some((x) => String(x.id) === want)) pupils.unshift(await api('GET', `/pupils/${encodeURIComponent(want)}`));
        $('pupil').append(el('option', { value: '' }, t('theory.choose_pupil')),
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
  FL.wordPage('theory.title').then(init);
})();
