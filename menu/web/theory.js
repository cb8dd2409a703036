// The theory exam: GET /api/theory describes it; POST /api/theory/attempts hands out a paper
// (questions drawn from the bank with a seed, no answers); POST .../answers has the server mark it
// and store the result as an exam record; ?attempt=N shows a paper again (marked or not).
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, pct, dateTime, param, isStaff } = FL;
  const me = requireLogin();
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  let info = null, attempt = null, warnedUnanswered = false;

  function show(section) {
    for (const id of ['intro', 'paper', 'result']) $(id).hidden = id !== section;
  }

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

  function paper(a) {
    attempt = a;
    warnedUnanswered = false;
    $('paper-intro').textContent = `${a.questions.length} questions. Choose one answer to each; you pass with ${pct(a.pass_mark)} right. ` +
      'Nothing is marked until you hand in.';
    const box = clear($('questions'));
    a.questions.forEach((q, i) => {
      const name = `q-${q.id}`;
      box.append(el('fieldset', { class: 'question', 'data-question': q.id },
        el('legend', {}, `${i + 1}. ${q.text}`),
        el('p', { class: 'topic' }, `Question ${i + 1} of ${a.questions.length} · ${q.topic_title}`),
        q.choices.map((c, k) => el('label', { class: 'choice', for: `${name}-${k}` },
          el('input', { type: 'radio', name, id: `${name}-${k}`, value: k, onchange: progress }), c))));
    });
    progress();
    show('paper');
    history.replaceState(null, '', `theory.html?attempt=${encodeURIComponent(a.id)}`);
  }

  function result(a) {
    const r = a.result;
    const summary = clear($('result-summary'));
    summary.append(
      el('p', { class: r.passed ? 'ok' : 'error', id: 'verdict' }, r.passed ? 'Passed.' : 'Not passed.'),
      el('p', {}, `${r.correct} of ${r.total} right: ${pct(r.score)}; the pass mark is ${pct(r.pass_mark)}.`),
      el('p', { class: 'muted', id: 'stored' }, `Recorded as theory exam ${r.exam_id} on ${dateTime(r.taken_at)}`,
         r.marked_by ? `, handed in by ${r.marked_by}` : '', `. Paper ${a.id}, drawn with seed ${a.seed}.`));
    clear($('by-topic').querySelector('tbody')).append(...Object.entries(r.by_topic).map(([t, v]) => {
      const title = (info && info.topics.find((x) => x.id === t) || { title: t }).title;
      return el('tr', {}, el('th', { scope: 'row' }, title), el('td', { class: 'num' }, `${v.correct} of ${v.total}`));
    }));
    const box = clear($('answers'));
    r.items.forEach((q, i) => {
      box.append(el('div', { class: `question ${q.right ? 'right' : 'wrong'}`, 'data-question': q.id },
        el('p', {}, el('strong', {}, `${i + 1}. ${q.right ? 'Right' : 'Wrong'}: `), q.text),
        el('ul', {}, (q.choices || []).map((c, k) => el('li', {}, c,
          k === q.answer ? el('strong', {}, ' (the right answer)') : '', k === q.chosen && k !== q.answer ? el('em', {}, ' (your answer)') : ''))),
        q.chosen === null ? el('p', { class: 'warn' }, 'Not answered.') : '',
        el('p', { class: 'explanation small' }, q.explanation, q.reference ? el('span', { class: 'muted' }, ` (${q.reference})`) : '')));
    });
    show('result');
    history.replaceState(null, '', `theory.html?attempt=${encodeURIComponent(a.id)}`);
  }

  $('paper').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    const answers = chosen();
    const missing = attempt.questions.length - Object.keys(answers).length;
    if (missing > 0 && !warnedUnanswered) {
      warnedUnanswered = true;
      say(message, `${missing} question${missing === 1 ? ' is' : 's are'} not answered and will count as wrong. Press "Hand in" again to hand in anyway.`, 'warn');
      return;
    }
    $('hand-in').disabled = true;
    try {
      const a = await api('POST', `/theory/attempts/${encodeURIComponent(attempt.id)}/answers`, { answers });
      clear(message);
      result(a);
      window.scrollTo(0, 0);
    } catch (e) {
      say(message, describeError(e));
      $('hand-in').disabled = false;
    }
  });

  $('begin').addEventListener('click', async () => {
    const body = {};
    if (isStaff(me)) {
      body.pupil_id = Number($('pupil').value);
      if (!body.pupil_id) { say(message, 'Choose the pupil who takes the exam.'); return; }
    }
    try {
      clear(message);
      paper(await api('POST', '/theory/attempts', body));
      window.scrollTo(0, 0);
    } catch (e) {
      say(message, describeError(e));
    }
  });

  async function init() {
    try {
      info = await api('GET', '/theory');
      const id = param('attempt');
      if (id) {
        const a = await api('GET', `/theory/attempts/${encodeURIComponent(id)}`);
        if (a.marked) result(a); else paper(a);
        return;
      }
      $('intro-text').textContent = `The exam has ${info.questions_per_exam} multiple-choice questions drawn at random from a bank of ` +
        `${info.questions_in_bank}, covering every topic below. The server marks it; you pass with ${pct(info.pass_mark)} right, ` +
        'and the result is stored on your record.';
      $('pass-why').textContent = info.pass_mark_why;
      clear($('topics').querySelector('tbody')).append(...info.topics.map((t) => el('tr', {},
        el('th', { scope: 'row' }, t.title), el('td', {}, t.osha), el('td', { class: 'num' }, t.questions))));
      if (isStaff(me)) {
        const pupils = await api('GET', '/pupils?limit=1000');
        const want = param('pupil');
        $('pupil').append(el('option', { value: '' }, 'choose a pupil'),
          ...pupils.map((p) => el('option', { value: p.id, selected: String(p.id) === want }, p.name)));
        $('for-pupil').hidden = false;
      }
      show('intro');
    } catch (e) {
      say(message, describeError(e));
    }
  }
  init();
})();
