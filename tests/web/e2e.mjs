// The web pages end to end, as a driving school uses them: a real forklift-server on a free
// loopback port with its own DDS domain (both from forklift-test-alloc) and a fresh SQLite file,
// a real sim worker driven by a scripted forklift-cab, and Debian's headless Chromium driven
// through playwright-core.
//
//   log in -> add an examiner on the staff page, reset, deactivate, reactivate -> add a pupil -> choose a scenario, truck and
//   cab, start a training drive, and a practical exam on the exam course on a second cab -> follow the exam live -> watch
//   both run on the fleet page -> the examiner aborts the exam, and the training drive finishes -> the session page (path
//   over the plan, timeline, mark) -> the pupil's page, whose chart has the training mark and no exam mark -> hand the pupil
//   a supervised theory exam -> log in as the pupil, take it against its clock, see the topics and clauses to read (not the
//   answers) and the record with its supervisor -> a practice quiz that does not count.
//
// The training cab drives its scenario's shipped clean drive (data/evaluation/scripts/), so its
// session completes its task and gets a mark. The exam course's clean drive takes 255 s of real
// time: the suite drives it once (ctest's fixture security_exam_course_drive), and certificate.mjs
// takes the licence and the certificate on from there.
//
// The marks are the worker's evaluator's: the server believes no other sender.
//
// Any page error, console error, failed request or unexpected HTTP error fails the test, as does
// any expected element that does not appear. Screenshots of each page go to --screenshots (default
// <out>/screenshots); docs/web/ holds a copy made with `--screenshots docs/web` (with certificate.mjs's).
//
//   BUILD/tests/forklift-test-alloc node e2e.mjs --bin BUILD/bin --data data
//                [--chromium /usr/bin/chromium] [--out DIR] [--screenshots DIR] [--headed]
//
// forklift-test-alloc takes the port and the DDS domain from the tests' allocator
// (tests/support/ports.h), holds them while this test and its children run, and passes them in
// FORKLIFT_TEST_PORT and FORKLIFT_TEST_DOMAIN.
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { setup, check, sleep, supports, Processes, apiOf, browserPage, shooter, logInAs, failed } from './harness.mjs';

// ---------------------------------------------------------------- arguments and helpers
const { args, port, domain, out } = setup('web-e2e');
const shots = path.resolve(args.screenshots || path.join(out, 'screenshots'));
fs.mkdirSync(shots, { recursive: true });
const started = Date.now();
const procs = new Processes(out);
const start = (...a) => procs.start(...a), tail = (...a) => procs.tail(...a), stopAll = () => procs.stopAll();

// ---------------------------------------------------------------- the platform
const base = `http://127.0.0.1:${port}`;
const adminPassword = 'web-admin-pass';
const serverBin = path.join(args.bin, 'forklift-server');
const cabBin = path.join(args.bin, 'forklift-cab');
// The school's DDS Security material (exams need it): a CA, the two cabs with their workers, the server.
const pki = path.join(out, 'pki');
const pkiTool = path.join(path.dirname(args.data), 'scripts', 'forklift-pki.sh');
fs.rmSync(pki, { recursive: true, force: true });
execFileSync(pkiTool, ['init', pki, '--school', 'Web School'], { stdio: 'ignore' });
for (const cab of ['webcab1', 'webcab2']) execFileSync(pkiTool, ['add-cab', pki, cab], { stdio: 'ignore' });
execFileSync(pkiTool, ['issue', pki, 'server', 'main'], { stdio: 'ignore' });
const serverArgs = ['--db', path.join(out, 'forklift.db'), '--listen', `127.0.0.1:${port}`, '--dds-domain', String(domain),
                    '--admin-password', adminPassword, '--log-dir', path.join(out, 'logs'), '--security', pki];
// A little cab video, for the examiner's live view: two cores are shared.
if (supports(serverBin, '--frame-fps')) serverArgs.push('--frame-fps', '4', '--frame-size', '480x360');
const server = start('server', serverBin, serverArgs);

const api = apiOf(base);

// ---------------------------------------------------------------- the browser
const { browser, page, problems, step } = await browserPage(args);

const shot = shooter(page, shots);

const bank = JSON.parse(fs.readFileSync(path.join(args.data, 'theory', 'questions.json'), 'utf8'));
let adminToken, adminId, pupilId, sessionId, examId, mark;

try {
  await step('the server answers', async () => {
    for (let i = 0; i < 100; i++) {
      try { if ((await fetch(base + '/api/health')).ok) return; } catch (e) { /* not yet */ }
      if (server.exitCode !== null) break;
      await sleep(100);
    }
    throw new Error('the server did not come up:\n' + tail('server'));
  });
  ({ token: adminToken, user_id: adminId } = await api('POST', '/login', null, { username: 'admin', password: adminPassword }));

  await step('log in as the administrator', async () => {
    await page.goto(base + '/');
    await page.waitForSelector('#login');
    await page.fill('#username', 'admin');
    await page.fill('#password', 'wrong password');
    await page.click('#login button[type=submit]');
    await page.waitForSelector('#message .error');  // refused, and said so
    problems.splice(0);  // the 401 and its console line were the point
    await page.fill('#password', adminPassword);
    await shot('login');
    await page.click('#login button[type=submit]');
    await page.waitForURL(/fleet\.html$/);
    await page.waitForSelector('#top .who');
    check((await page.textContent('#top .who')).includes('admin'), 'the top bar names the login');
  });

  // Staff administration: the staff page, for admins only.
  await step('add an examiner on the staff page, reset their password, deactivate and reactivate them', async () => {
    await page.click('#top a[href="staff.html"]');
    await page.waitForSelector('#staff tbody tr');
    await page.fill('#full-name', 'Erin <b>Examiner</b>');  // data is shown as text, never as HTML
    await page.selectOption('#role', 'examiner');
    await page.fill('#new-username', 'erin');
    await page.fill('#new-password', 'erin-pass-1');
    await page.click('#add button[type=submit]');
    const erinRow = '#staff tbody tr:has(td:text-is("erin"))';
    await page.waitForSelector(erinRow);
    check((await page.textContent(`${erinRow} th`)) === 'Erin <b>Examiner</b>', 'the full name is shown as typed');
    check((await page.textContent('#count')).includes('of 2 accounts'), `the total: ${await page.textContent('#count')}`);
    await page.click(`${erinRow} button[data-action=reset]`);
    await page.fill(`${erinRow} input[type=password]`, 'erin-pass-2');
    await page.click(`${erinRow} form button[type=submit]`);
    await page.waitForFunction(() => /New password set for erin/.test(document.getElementById('message').textContent));
    await page.click(`${erinRow} button[data-action=deactivate]`);
    await page.waitForSelector(`${erinRow} button[data-action=reactivate]`);
    check((await page.textContent(`${erinRow} .badge`)) === 'deactivated', 'the status says deactivated');
    const refused = await fetch(base + '/api/login', { method: 'POST', headers: { 'Content-Type': 'application/json' },
                                                       body: JSON.stringify({ username: 'erin', password: 'erin-pass-2' }) });
    check(refused.status === 403, `a deactivated examiner cannot log in: ${refused.status}`);
    await shot('staff');
    await page.click(`${erinRow} button[data-action=reactivate]`);
    await page.waitForSelector(`${erinRow} button[data-action=deactivate]`);
    const audit = await api('GET', '/staff-audit', adminToken);
    check(audit.map((r) => r.action).join() === 'account_reactivated,account_deactivated,password_reset,account_created',
          `each action audited: ${audit.map((r) => r.action).join()}`);
  });

  await step('add a pupil with a login, and find them by search', async () => {
    await page.click('#top a[href="pupils.html"]');
    await page.waitForSelector('#add');
    for (const [name, user] of [['Ben Lifter', null], ['Carla Reach', null], ['Ann Driver', 'ann']]) {
      await page.fill('#name', name);
      await page.fill('#email', `${name.split(' ')[0].toLowerCase()}@example.org`);
      if (user) {
        await page.fill('#new-username', user);
        await page.fill('#new-password', 'ann-pass-1');
      }
      await page.click('#add button[type=submit]');
      await page.waitForFunction((n) => document.querySelector('#added-pupil') && document.querySelector('#added-pupil').textContent === n, name);
    }
    pupilId = Number(new URL(await page.getAttribute('#added-pupil', 'href'), base).searchParams.get('id'));
    check(pupilId > 0, 'the new pupil has an id');
    await page.fill('#search', 'ann d');
    await page.waitForFunction(() => document.querySelectorAll('#pupils tbody tr').length === 1);
    check((await page.textContent('#pupils tbody')).includes('Ann Driver'), 'the search finds Ann');
    await page.fill('#search', '');
    await page.waitForFunction(() => document.querySelectorAll('#pupils tbody tr').length === 3);
    await shot('pupils');
  });

  // The cab stations come on line: each announces itself and waits for a worker. webcab1 for a
  // training drive round the yard, webcab2 for a practical exam on the exam course.
  const script = (name) => path.join(args.data, 'evaluation', 'scripts', name);
  const noWindow = supports(cabBin, '--no-window') ? ['--no-window'] : [];
  start('cab', cabBin, ['--cab', 'webcab1', '--script', script('first_drive_yard_exam.csv'), '--dds-domain', String(domain), '--wait-worker', '90',
                        '--security', pki, ...noWindow]);
  // The exam's cab saves its frames, so it asks the worker for them (as a cab with a window does):
  // the examiner's live view has frames to show.
  start('cab2', cabBin, ['--cab', 'webcab2', '--script', script('counterbalance_exam_clean.csv'),
                         '--dds-domain', String(domain), '--wait-worker', '90', '--security', pki, ...noWindow,
                         '--save-frame', path.join(out, 'webcab2-last-frame.png')]);

  await step('the cabs come on line', async () => {
    for (let i = 0; i < 100; i++) {
      const f = await api('GET', '/fleet', adminToken);
      if (['webcab1', 'webcab2'].every((id) => f.cabs.some((c) => c.id === id && c.online))) return;
      await sleep(200);
    }
    throw new Error('a cab never announced itself:\n' + tail('cab') + '\n' + tail('cab2'));
  });

  await step('choose scenario, truck and cab, and start a training session', async () => {
    await page.goto(`${base}/start.html?pupil=${pupilId}`);
    await page.waitForSelector('#scenario option[value="first_drive_yard"]', { state: 'attached' });
    check(await page.inputValue('#pupil') === String(pupilId), 'the pupil is chosen');
    check((await page.textContent('#cab-about')).includes('webcab1'), 'the cab is listed online');
    // An exam runs only on an exam course: the others are offered for training alone.
    await page.selectOption('#mode', 'exam');
    check(await page.$eval('#scenario option[value="first_drive_yard"]', (o) => o.disabled), 'a training scenario cannot start an exam');
    check(await page.isDisabled('#truck'), 'an exam drives the course\'s own truck');
    check(await page.isHidden('#aids-set') && await page.isVisible('#aids-exam'), 'an exam\'s forbidden aids are hidden, not shown ticked');
    await page.selectOption('#mode', 'training');
    check(await page.isVisible('#aids-set') && await page.isHidden('#aids-exam'), 'training offers the aids');
    await page.selectOption('#scenario', 'first_drive_yard');
    await page.selectOption('#truck', 'linde_e16c');
    await page.fill('#cab', 'webcab1');
    await shot('start');
    await page.click('#start-button');
    await page.waitForFunction(() => /Session s-\d+/.test(document.getElementById('started-status').textContent));
    sessionId = (await page.textContent('#started-status')).match(/s-\d+/)[0];
    // The practical exam on the other cab, through the API as the menu would start it.
    examId = (await api('POST', '/sessions', adminToken, { pupil_id: pupilId, cab_id: 'webcab2', scenario: 'counterbalance_exam',
                                                            mode: 'exam' })).id;
  });

  await step('follow the exam live, as a remote examiner', async () => {
    await page.goto(`${base}/session.html?id=${examId}`);
    await page.waitForFunction(() => !document.getElementById('live').hidden
                                     && /Speed/.test(document.getElementById('live-state').textContent));
    // The cab's view as the worker renders it, fetched with the token and shown from a blob.
    await page.waitForFunction(() => { const i = document.getElementById('live-frame'); return !i.hidden && i.complete && i.naturalWidth === 480; },
                               null, { timeout: 30000 });
    check(/Abort/.test(await page.textContent('#actions')), 'the examiner can abort it');
    // The time the course leaves (10 minutes) and the pupil's place in its task, in words.
    const left = await page.textContent('#live-time-left');
    check(/^(\d+ min )?\d+ s$/.test(left) && !left.startsWith('10 min 1'), `the time left: ${left}`);
    const task = await page.textContent('#live-task');
    check(/^\d of 8 steps done; now: [A-Z]/.test(task), `the task's steps, done of total, and the current one in words: ${task}`);
    await shot('session-live');
  });

  // The instructor's hand on the training drive, from its live page: pause it (the truck and its
  // clock wait; the scripted cab's rows wait with it, as they follow the truck's time), put a line
  // on the pupil's display, and resume. The exam's page offers none of it: an exam is only
  // watched, or aborted.
  await step('pause the training drive, message the pupil and resume it', async () => {
    check(await page.isHidden('#instructor'), 'an exam offers no pause and no message');
    check(await page.isHidden('#hazards'), 'nor a hazard to start');
    await page.goto(`${base}/session.html?id=${sessionId}`);
    await page.waitForSelector('#instructor', { state: 'visible' });
    check(await page.getAttribute('#pause', 'aria-pressed') === 'false', 'the drive runs');
    await page.click('#pause');
    await page.waitForSelector('#live-paused');
    check(await page.getAttribute('#pause', 'aria-pressed') === 'true' && /Resume/.test(await page.textContent('#pause')),
          'the button now resumes');
    const before = (await api('GET', `/sessions/${sessionId}/live`, adminToken)).state.sim_time_s;
    await sleep(600);
    const after = (await api('GET', `/sessions/${sessionId}/live`, adminToken)).state.sim_time_s;
    check(before === after, `the truck's time stands while paused (${before} s, then ${after} s)`);
    const said = 'Good so far: keep below the walkway limit';
    await page.fill('#say-text', said);
    await page.click('#say-form button[type="submit"]');
    await page.waitForFunction((t) => { const s = document.getElementById('live-said'); return s && s.textContent === t; }, said);
    await shot('session-paused');
    await page.click('#pause');
    await page.waitForFunction(() => document.getElementById('live-paused') === null
                                     && document.getElementById('pause').getAttribute('aria-pressed') === 'false');
    const audit = await api('GET', `/pupils/${pupilId}/audit`, adminToken);
    for (const action of ['session_paused', 'instructor_message_sent', 'session_resumed'])
      check(audit.some((r) => r.action === action && r.details.session === sessionId), `the pupil's record has ${action}`);
  });

  await step('watch them run on the fleet page', async () => {
    await page.click('#top a[href="fleet.html"]');
    for (const id of [sessionId, examId]) {
      const row = `#cabs tr[data-session="${id}"]`;
      await page.waitForSelector(row);
      await page.waitForFunction((r) => { const w = document.querySelector(`${r} td.worker`); return w && w.textContent.includes('healthy'); }, row);
      check((await page.textContent(row)).includes('Ann Driver'), 'the fleet says for whom');
    }
    await shot('fleet');
  });

  // The exam course's clean drive is 255 s; the suite drives it once (ctest's fixture
  // security_exam_course_drive). Here the examiner stops this one from the fleet page.
  await step('the examiner aborts the exam, and the training drive finishes', async () => {
    const abort = `#cabs tr[data-session="${examId}"] button[data-key="abort ${examId}"]`;
    await page.click(abort);
    await page.waitForFunction((sel) => { const b = document.querySelector(sel); return b && /Confirm: abort/.test(b.textContent); }, abort);
    await page.click(abort);
    for (const [id, end] of [[sessionId, 'ended'], [examId, 'aborted']]) {
      await page.waitForSelector(`#finished tr[data-session="${id}"]`, { timeout: 240000 });
      const state = await page.textContent(`#finished tr[data-session="${id}"] td.state`);
      check(state.includes(end), `session ${id} ${end} (the fleet says: ${state})`);
      check(!(await page.$(`#cabs tr[data-session="${id}"]`)), 'its cab is idle again');
    }
    await shot('fleet-finished');
  });

  // The mark a session got from its worker's evaluator (the server believes no other sender).
  async function markOf(id) {
    let s = await api('GET', `/sessions/${id}`, adminToken);
    for (let i = 0; i < 50 && s.mark === null; i++) { await sleep(100); s = await api('GET', `/sessions/${id}`, adminToken); }
    check(s.mark !== null, `session ${id} has a mark`);
    return s;
  }

  await step('the training drive is marked, and the aborted exam is not', async () => {
    mark = (await markOf(sessionId)).mark;
    // Its control log reaches the store just after the mark; until then its replay answers 503
    // (not_ready) and the session page asks again, which the browser reports as an error.
    for (let i = 0; i < 100; i++) {
      const r = await fetch(`${base}/api/sessions/${sessionId}/replay`, { headers: { Authorization: `Bearer ${adminToken}` } });
      if (r.status !== 503) { check(r.ok, `the replay of ${sessionId}: HTTP ${r.status}`); break; }
      await sleep(200);
    }
    const aborted = await api('GET', `/sessions/${examId}`, adminToken);
    check(aborted.mark === null && aborted.outcome === 'aborted', `an aborted exam has no mark: ${JSON.stringify(aborted)}`);
    process.stdout.write(`(training ${mark}) `);
  });

  await step("the session page: path over the plan, timeline, mark", async () => {
    await page.goto(`${base}/session.html?id=${sessionId}`);
    await page.waitForSelector('#plan-svg');
    await page.waitForFunction(() => { const p = document.getElementById('truck-path'); return p && Number(p.dataset.points) >= 5; });
    await page.waitForSelector('#plan-svg [data-object="CONTAINER_1"]', { state: 'attached' });  // the yard is drawn
    await page.waitForFunction((m) => { const e = document.getElementById('mark'); return e && e.textContent === m; }, mark.toFixed(1));
    const facts = await page.textContent('#facts');
    check(facts.includes('Linde'), `the session shows the truck chosen: ${facts}`);
    const events = await page.$$('#timeline li[data-seq]');
    if (events.length > 0) {
      await page.click('#timeline li[data-seq] button.link');
      await page.waitForSelector('#plan-svg .event.current', { state: 'attached' });
    }
    const s = await api('GET', `/sessions/${sessionId}`, adminToken);
    if (s.stills_available && events.length > 0) {  // the renderer has been built
      await page.click('#timeline li[data-seq] .still button');
      await page.waitForSelector('#timeline li[data-seq] .still img', { timeout: 90000 });
    }
    await shot('session');
  });

  await step("the pupil's page has the new mark in its chart", async () => {
    await page.goto(`${base}/pupil.html?id=${pupilId}`);
    await page.waitForFunction(() => window.Chart && Chart.getChart(document.getElementById('marks-chart')));
    // Training marks and exam results apart: one series each; the aborted exam has no mark.
    const [training, exams] = await page.evaluate(() => Chart.getChart(document.getElementById('marks-chart')).data.datasets.map((d) => d.data));
    check(training.includes(mark), `the training series holds ${mark}: ${JSON.stringify(training)}`);
    check(exams.filter((m) => m !== null).length === 0, `the exam series holds no mark: ${JSON.stringify(exams)}`);
    check((await page.textContent('#marks-table')).includes(sessionId), 'the chart\'s table lists the session');
    const label = await page.getAttribute('#marks-chart', 'aria-label');
    check(label.includes('1 marked training sessions and 0 marked practical exams'), `the chart says what it shows: ${label}`);
    await page.waitForSelector(`#sessions tr[data-session="${sessionId}"]`);
  });

  // The pupil's choices as the paper shows them (shuffled): the place of the right one, by its text.
  const byId = Object.fromEntries(bank.questions.map((q) => [q.id, q]));
  async function answerPaper(wrong) {
    const shown = await page.$$eval('fieldset.question', (fs) => fs.map((f) => ({
      id: f.dataset.question, choices: [...f.querySelectorAll('label.choice')].map((l) => l.textContent) })));
    for (const [i, q] of shown.entries()) {
      const b = byId[q.id];
      const right = q.choices.indexOf(b.choices[b.answer]);
      check(right >= 0, `question ${q.id} shows its right answer among its choices`);
      await page.check(`#q-${q.id}-${i < wrong ? (right + 1) % q.choices.length : right}`);
    }
    await page.waitForFunction((n) => document.getElementById('progress').textContent.startsWith(`${n} of ${n}`), shown.length);
    return shown;
  }

  await step('hand the pupil a supervised theory exam', async () => {
    await page.goto(`${base}/theory.html?pupil=${pupilId}`);
    await page.waitForFunction(() => document.getElementById('exam-standing').dataset.code === 'allowed');
    check(await page.inputValue('#pupil') === String(pupilId), 'the pupil is chosen');
    check(!(await page.isDisabled('#begin-exam')), 'the examiner may start an exam');
    await page.click('#begin-exam');
    await page.waitForSelector('#handed:not([hidden])');
    const handed = await page.textContent('#handed-text');
    check(handed.includes('Ann Driver') && handed.includes('supervised by admin'), `the paper is handed out under supervision: ${handed}`);
    await page.waitForFunction(() => document.getElementById('exam-standing').dataset.code === 'paper_open');
    check((await page.textContent('#papers tbody')).includes('open until'), 'the open paper is listed');
    await shot('theory-handout');
  });

  await step('log out, and log in as the pupil', async () => {
    await page.click('#top button.link');
    await page.waitForURL(/index\.html$/);
    await logInAs(page, 'ann', 'ann-pass-1', new RegExp(`pupil\\.html\\?id=${pupilId}$`));
    await page.waitForSelector('#facts dt');
  });

  let verdict;
  await step('take the supervised theory exam, against its clock', async () => {
    await page.click('#top a[href="theory.html"]');
    await page.waitForSelector('#topics tbody tr');
    check((await page.$$('#topics tbody tr')).length === Object.keys(bank.topics).length, 'every topic is listed');
    await page.waitForSelector('#open-paper:not([hidden])');
    check((await page.textContent('#exam-standing')).includes('supervised by admin'), 'the pupil is told who supervises the paper');
    await page.click('#open-paper');
    await page.waitForSelector('fieldset.question');
    check(await page.getAttribute('#paper-kind', 'data-kind') === 'exam', 'a supervised exam paper');
    await page.waitForFunction(() => /^Time left \d+:\d\d/.test(document.getElementById('clock').textContent));
    const left = Number(await page.getAttribute('#clock', 'data-left'));
    check(left > 60 && left <= 45 * 60, `the time limit is shown and counting: ${left} s left`);
    const shown = await answerPaper(1);  // one wrong on purpose
    check(shown.length === bank.questions_per_exam, `${bank.questions_per_exam} questions on the paper`);
    for (const img of await page.$$('fieldset.question .picture')) {  // a question about a sign, plate or chart
      await img.waitForSelector('img');
      check(await img.$eval('img', (i) => i.complete && i.naturalWidth > 0 && i.alt.length > 0), 'its picture is shown, with words');
    }
    await page.evaluate(() => window.scrollTo(0, 0));
    await shot('theory-paper', { fullPage: false });
    await page.click('#hand-in');
    await page.waitForSelector('#verdict');
    verdict = await page.textContent('#result-summary');
    check(verdict.includes(`${shown.length - 1} of ${shown.length} right`), `marked by the server: ${verdict}`);
    check((await page.textContent('#verdict')) === 'Passed.', 'passed');
    check(verdict.includes('supervised by admin'), `the result names its supervisor: ${verdict}`);
    // The topic missed and the clause to read; not the answer.
    const missed = byId[shown[0].id];
    const revise = await page.textContent('#to-revise');
    check(revise.includes(missed.reference), `the clause to read is named: ${revise}`);
    const text = await page.textContent('main');
    check(!text.includes(missed.explanation) && !text.includes('right answer'), 'the page does not give the answer away');
    await shot('theory-result', { fullPage: false });
  });

  await step('the exam is stored, with its supervisor', async () => {
    const h = await api('GET', `/pupils/${pupilId}/history`, adminToken);
    const theory = h.exams.filter((e) => e.kind === 'theory');
    check(theory.length === 1 && theory[0].passed && theory[0].correct === bank.questions_per_exam - 1 && theory[0].examiner === 'admin',
          `one passed theory exam record, examined by admin: ${JSON.stringify(theory)}`);
    await page.click('#top a[href^="pupil.html"]');
    await page.waitForSelector('#exams tr[data-kind="theory"]');
    await page.waitForFunction(() => window.Chart && Chart.getChart(document.getElementById('faults-chart')));
    await shot('pupil');
  });

  await step('a practice quiz is marked, and does not count', async () => {
    await page.click('#top a[href="theory.html"]');
    await page.waitForSelector('#begin-practice:not([hidden]):not([disabled])');
    check(await page.$('#begin-exam[hidden]') !== null, 'a pupil cannot start an exam');
    await page.click('#begin-practice');
    await page.waitForSelector('fieldset.question');
    check(await page.getAttribute('#paper-kind', 'data-kind') === 'practice', 'a practice paper');
    await answerPaper(0);
    await page.click('#hand-in');
    await page.waitForSelector('#practice-result');
    check((await page.textContent('#verdict')) === 'Passed.', 'the quiz is marked');
    const h = await api('GET', `/pupils/${pupilId}/history`, adminToken);
    check(h.exams.filter((e) => e.kind === 'theory').length === 1, 'still one theory exam on the record');
    await page.click('#back');
    await page.waitForSelector('#papers tr[data-kind="practice"]');
  });

  console.log(`web e2e: all steps passed in ${((Date.now() - started) / 1000).toFixed(1)} s; screenshots in ${shots}`);
  await browser.close();
  await stopAll();
  process.exit(0);
} catch (e) {
  const running = server.exitCode === null && server.signalCode === null;
  await failed(e, { page, out, problems, browser, procs, logs: `server ${running ? 'running' : `exited (${server.exitCode ?? server.signalCode})`}\n` +
                    `--- server log (tail) ---\n${tail('server')}\n--- cab logs (tail) ---\n${tail('cab')}\n${tail('cab2')}` });
}
