// The certificate in the browser, as a school, its pupil and an employer read it: a real
// forklift-server on a copy of the school the exam course's live drive left (--school: ctest's
// fixture security_exam_course_drive, tests/CMakeLists.txt), whose pupil Ann Driver passed the
// practical exam on the exam course, and Debian's headless Chromium driven through playwright-core.
//
//   Ann's page shows her exam's mark -> she passes a supervised theory exam -> no certificate before
//   the licence -> the examiner issues the licence -> the certificate, listing her training sessions,
//   whose QR code opens the verification page at the school's public address (--public-url) for
//   anyone (no login): valid -> the examiner revokes it, and the
//   verification page says so -> Ann reads Spanish: a licence issued again comes with a certificate
//   in her language, which her page and anyone's verification show with no English word left.
//
//   BUILD/tests/forklift-test-alloc node certificate.mjs --bin BUILD/bin --data data --school BUILD/tests/fixtures/exam-course
//                [--chromium /usr/bin/chromium] [--out DIR] [--screenshots DIR] [--headed]
import fs from 'node:fs';
import path from 'node:path';
import { setup, check, sleep, Processes, apiOf, browserPage, shooter, logInAs, failed, axeFindings, englishMessages, englishLeft } from './harness.mjs';

let jsQR;
try {
  ({ default: jsQR } = await import('jsqr'));
} catch (e) {
  console.error('certificate: jsqr is missing: run `npm ci --prefix tests/web` (scripts/install-deps.sh does)');
  process.exit(1);
}

const { args, port, domain, out } = setup('web-certificate');
const shots = path.resolve(args.screenshots || path.join(out, 'screenshots'));
fs.mkdirSync(shots, { recursive: true });
const started = Date.now();
const procs = new Processes(out);

// The school the exam course's drive left, copied: its database, workers' logs and DDS Security
// folder, and who is who.
if (!args.school || !fs.existsSync(path.join(args.school, 'school.json'))) {
  console.error('certificate: no --school with a school.json: run it through ctest, whose fixture security_exam_course_drive makes it');
  process.exit(2);
}
const made = JSON.parse(fs.readFileSync(path.join(args.school, 'school.json'), 'utf8'));
for (const part of ['forklift.db', 'forklift.db.logs', 'pki']) fs.cpSync(path.join(args.school, part), path.join(out, part), { recursive: true });
const base = `http://127.0.0.1:${port}`;
// The school's public address, as employers reach it (--public-url): the same server under another
// name than the one the examiner's browser uses, so the QR code shows which one it carries.
const publicBase = `http://localhost:${port}`;
const adminPassword = made.admin_password;
const annId = made.pupil;
const [annUser, annPassword] = made.logins.pupil;
const server = procs.start('server', path.join(args.bin, 'forklift-server'),
                           ['--db', path.join(out, 'forklift.db'), '--listen', `127.0.0.1:${port}`, '--dds-domain', String(domain),
                            '--security', path.join(out, 'pki'), '--frame-fps', '0', '--public-url', publicBase]);
const api = apiOf(base);
const { browser, page, problems, step } = await browserPage(args);

const shot = shooter(page, shots);

let adminToken, adminId;
try {
  await step('the server answers on the copied school', async () => {
    for (let i = 0; i < 100; i++) {
      try { if ((await fetch(base + '/api/health')).ok) break; } catch (e) { /* not yet */ }
      if (server.exitCode !== null) throw new Error('the server stopped:\n' + procs.tail('server'));
      await sleep(100);
    }
    ({ token: adminToken, user_id: adminId } = await api('POST', '/login', null, { username: 'admin', password: adminPassword }));
  });

  await step("Ann's page shows her exam on the exam course, marked and passed", async () => {
    const exam = await api('GET', `/sessions/${made.session}`, adminToken);
    check(exam.passed === true && exam.outcome === 'completed' && exam.mark !== null, `the clean drive passed: ${JSON.stringify(exam)}`);
    await page.goto(base + '/');
    await page.waitForSelector('#login');
    await logInAs(page, 'admin', adminPassword, /fleet\.html$/);
    await page.goto(`${base}/pupil.html?id=${annId}`);
    await page.waitForSelector('#exams tr[data-kind="practical"]');
    await page.waitForFunction(() => window.Chart && Chart.getChart(document.getElementById('marks-chart')));
    const [, exams] = await page.evaluate(() => Chart.getChart(document.getElementById('marks-chart')).data.datasets.map((d) => d.data));
    check(exams.includes(exam.mark), `her exam series holds ${exam.mark}: ${JSON.stringify(exams)}`);
  });

  // The theory exam, handed out and in at a supervised station: each question's right choice.
  await step('she passes a supervised theory exam', async () => {
    const bank = JSON.parse(fs.readFileSync(path.join(args.data, 'theory', 'questions.json'), 'utf8'));
    const paper = await api('POST', '/theory/attempts', adminToken, { pupil_id: annId });
    const answers = {};
    for (const q of paper.questions) {
      const b = bank.questions.find((x) => x.id === q.id);
      answers[q.id] = q.choices.indexOf(b.choices[b.answer]);
    }
    const marked = await api('POST', `/theory/attempts/${paper.id}/answers`, adminToken, { answers });
    check(marked.result.passed === true, `the paper is passed: ${JSON.stringify(marked.result)}`);
  });

  await step('log in as Ann', async () => {
    await page.click('#top button.link');
    await page.waitForURL(/index\.html$/);
    await logInAs(page, annUser, annPassword, new RegExp(`pupil\\.html\\?id=${annId}$`));
    await page.waitForSelector('#facts dt');
  });

  await step('no certificate before the licence', async () => {
    await page.click('#top a[href^="certificate.html"]');
    await page.waitForSelector('#message .warn');
    check((await page.textContent('#message')).includes('no licence has been issued'), 'the page says the licence comes first');
    check(await page.isDisabled('#print'), 'nothing to print');
    problems.splice(0);  // the 409 and its console line were the point
  });

  // The certificate names people by their full names: the administrator gives theirs first.
  await step('the examiner issues the licence', async () => {
    await api('PATCH', `/users/${adminId}`, adminToken, { full_name: 'Alex Admin' });
    await page.click('#top button.link');
    await page.waitForURL(/index\.html$/);
    await logInAs(page, 'admin', adminPassword, /fleet\.html$/);
    await page.goto(`${base}/pupil.html?id=${annId}`);
    await page.waitForSelector('#issue-licence');
    await page.click('#issue-licence');
    await page.waitForFunction(() => /Licence issued, with certificate /.test(document.getElementById('message').textContent));
    await page.waitForSelector('#certificate-link');
  });

  let verifyAt, number;
  await step('the certificate, with its number and QR code', async () => {
    await page.click('#certificate-link');
    await page.waitForSelector('#certificate:not([hidden])');
    check(await page.getAttribute('#verdict', 'data-status') === 'valid', 'the certificate is valid');
    check((await page.textContent('#cert-name')) === 'Ann Driver', 'the record names the operator');
    check((await page.textContent('#cert-school')) === made.school, 'the record names the school');
    const facts = await page.textContent('#cert-facts');
    check(facts.includes('Alex Admin') && facts.includes('Counterbalance truck practical test'), `it names the licence's issuer and the exam course: ${facts}`);
    // The training the record holds, each session with its date and mark, and nothing it does not.
    const trained = await page.$$eval('#cert-training li', (li) => li.map((x) => x.textContent));
    check(trained.length === 3 && trained.every((t) => / mark [0-9.]+ of 100$/.test(t)), `three marked training sessions listed: ${JSON.stringify(trained)}`);
    check(!facts.includes('no marked simulator training') && !(await page.textContent('#statement')).includes('formal instruction'),
          `it claims nothing the record does not hold: ${facts}`);
    const due = await page.textContent('#cert-due');
    check(Number(due.slice(0, 4)) === new Date().getUTCFullYear() + 3, `re-evaluation due in three years: ${due}`);
    number = await page.textContent('#cert-number');
    // The QR code read back from the canvas's pixels, as a phone would.
    const img = await page.$eval('#qr', (c) => ({ w: c.width, h: c.height, px: Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data) }));
    const code = jsQR(Uint8ClampedArray.from(img.px), img.w, img.h);
    check(code !== null, 'the QR code reads');
    verifyAt = code.data;
    check(verifyAt === `${publicBase}/verify.html?number=${encodeURIComponent(number)}`,
          `the QR code opens the verification page at the school's public address: ${verifyAt}`);
    check((await page.textContent('#verify-url')) === verifyAt, 'the printed link is the same address');
    await shot('certificate');
    const axe = await axeFindings(page);
    check(axe.serious.length === 0, `the certificate, usable by everyone: axe finds\n${axe.serious.join('\n')}`);
    await page.emulateMedia({ media: 'print' });
    await shot('certificate-print');
    await page.emulateMedia({ media: 'screen' });
  });

  // Anyone: a browser of its own, with no login.
  const anyone = await (await browser.newContext({ viewport: { width: 1280, height: 860 }, locale: 'en-GB', timezoneId: 'UTC' })).newPage();
  anyone.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  await step('anyone opens the verification page from the QR code', async () => {
    await anyone.goto(verifyAt);
    await anyone.waitForSelector('#result:not([hidden])');
    check(await anyone.getAttribute('#verdict', 'data-status') === 'valid', 'valid, for anyone');
    check((await anyone.textContent('#cert-number')) === number && (await anyone.textContent('#cert-name')) === 'Ann Driver', 'the certificate it checked');
    await shot('verify', { of: anyone });
    const axe = await axeFindings(anyone);
    check(axe.serious.length === 0, `the verification page, valid, usable by everyone: axe finds\n${axe.serious.join('\n')}`);
    // A number nobody issued.
    await anyone.fill('#number', number.slice(0, -1) + (number.endsWith('A') ? 'B' : 'A'));
    await anyone.click('#lookup button[type=submit]');
    await anyone.waitForFunction(() => document.getElementById('verdict') && document.getElementById('verdict').dataset.status === 'not_found');
  });

  await step('the examiner revokes it, and the verification page says so', async () => {
    await page.fill('#revoke-reason', 'Pupil re-examined after an incident');
    await page.click('#revoke button[type=submit]');
    await page.waitForFunction(() => document.getElementById('verdict').dataset.status === 'revoked');
    check(await page.isDisabled('#print'), 'a revoked certificate is not printed');
    await anyone.goto(verifyAt);
    await anyone.waitForSelector('#result:not([hidden])');
    check(await anyone.getAttribute('#verdict', 'data-status') === 'revoked', 'revoked, for anyone');
    check((await anyone.textContent('#revocation')).includes('Pupil re-examined after an incident'), 'with its reason');
  });

  // Spanish: Ann's record says she reads it, so the certificate issued now is worded in it (the
  // record says so, signed), and its pages follow the certificate, whoever opens them.
  await step('a certificate issued in Spanish shows Spanish, and verifies', async () => {
    const annRecord = await api('PATCH', `/pupils/${annId}`, adminToken, { language: 'es' });
    check(annRecord.language === 'es', `Ann's language is kept: ${JSON.stringify(annRecord)}`);
    // The examiner's choice wins over hers; left to the page's default, hers.
    await api('POST', `/pupils/${annId}/licence`, adminToken, { language: 'en' });
    check((await api('GET', `/pupils/${annId}/certificate`, adminToken)).certificate.language === 'en', 'issued in the language asked');
    await page.goto(`${base}/pupil.html?id=${annId}`);
    await page.waitForSelector('#issue-licence');
    check(await page.inputValue('#certificate-language') === '', "the page issues in the pupil's language unless told otherwise");
    await page.click('#issue-licence');
    await page.waitForFunction(() => /Licence issued, with certificate /.test(document.getElementById('message').textContent));
    const cert = await api('GET', `/pupils/${annId}/certificate`, adminToken);
    check(cert.status === 'valid' && cert.certificate.language === 'es', `the new certificate is in Spanish and valid: ${cert.status}`);
    check(cert.certificate.statement.startsWith('Este registro certifica'), `its signed statement is Spanish: ${cert.certificate.statement}`);
    // Every English message whose Spanish differs: none may be on a Spanish page.
    const english = englishMessages(args.data);
    // Names stay as they are: the school's, the people's, the certificate's number.
    const namesIn = (o) => Object.entries(o || {}).flatMap(([k, v]) =>
      (v && typeof v === 'object' ? namesIn(v) : ['name', 'username', 'school', 'number'].includes(k) && typeof v === 'string' ? [v] : []));
    const names = [...namesIn(cert.certificate), annUser];
    const englishLeftOn = (of) => englishLeft(of, english, names);
    await page.click('#top button.link');
    await page.waitForURL(/index\.html$/);
    await logInAs(page, annUser, annPassword, new RegExp(`pupil\\.html\\?id=${annId}$`));
    await page.goto(`${base}/certificate.html?pupil=${annId}`);
    await page.waitForSelector('#certificate:not([hidden])');
    check(await page.getAttribute('html', 'lang') === 'es', 'the page says it is Spanish');
    check((await page.textContent('#verdict')).includes('Válido'), `valid, in Spanish: ${await page.textContent('#verdict')}`);
    check((await page.textContent('#cert-facts')).includes('Examen práctico de carretilla contrapesada'), 'the exam course in Spanish');
    const left = await englishLeftOn(page);
    check(left.length === 0, `no English left on the Spanish certificate: ${JSON.stringify(left)}`);
    await shot('certificate-es');
    const axe = await axeFindings(page);
    check(axe.serious.length === 0, `the Spanish certificate, usable by everyone: axe finds\n${axe.serious.join('\n')}`);
    // Anyone's browser in English opens its QR code: the page follows the certificate.
    await anyone.goto(cert.verify_url);
    await anyone.waitForSelector('#result:not([hidden])');
    check(await anyone.getAttribute('#verdict', 'data-status') === 'valid', 'the Spanish certificate verifies, for anyone');
    check((await anyone.textContent('#verdict')).includes('Válido'), 'and says so in Spanish');
    const checks = await anyone.$$eval('#checks li', (li) => li.map((x) => x.textContent));
    check(checks.includes('la firma del servidor se verifica') && checks.some((c) => c.startsWith('el examen práctico ')),
          `what was checked, in Spanish: ${JSON.stringify(checks)}`);
    const leftThere = await englishLeftOn(anyone);
    check(leftThere.length === 0, `no English left on its verification page: ${JSON.stringify(leftThere)}`);
    await shot('verify-es', { of: anyone });
  });

  console.log(`web certificate: all steps passed in ${((Date.now() - started) / 1000).toFixed(1)} s; screenshots in ${shots}`);
  await browser.close();
  await procs.stopAll();
  process.exit(0);
} catch (e) {
  await failed(e, { page, out, problems, browser, procs, logs: `--- server log (tail) ---\n${procs.tail('server')}` });
}
