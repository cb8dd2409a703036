// Every page usable by everyone, against a real forklift-server, worker and cab:
// - a keyboard-only walk (Tab, Enter and Space, and typing into fields): an instructor logs in,
//   starts a session, opens it from the start page, and signs its debrief off; each control is
//   reached by Tab from where the focus was, never clicked;
// - axe-core (from package.json) finds no serious or critical violation on any page of menu/web:
//   the login, the fleet, the day, the pupils and a pupil's record, the start page, the sessions,
//   a session live and a finished one's debrief, the exams, the staff, the theory paper, the
//   pupil's certificate page and the public certificate check;
// - the same pages for an administrator and a pupil who read Spanish, chosen with the top bar's
//   language selector: no English message of the catalogues left on any, and axe still clean;
// - colour is never the only signal: every event and every marking-sheet level says its worry
//   level in words;
// - no text field cuts what it holds: each input is at least as wide as the text typed into it.
//
//   BUILD/tests/forklift-test-alloc node a11y.mjs --bin BUILD/bin --data data [--out DIR] [--headed]
import path from 'node:path';
import { setup, startServer, axeFindings, check, sleep, supports, Processes, apiOf, waitForServer, browserPage, failed, englishMessages,
         englishLeft } from './harness.mjs';

const test = setup('a11y');
const { args, domain, out, base } = test;
const procs = new Processes(out);
const api = apiOf(base);
const adminPassword = 'web-admin-pass';
const server = startServer(procs, test, adminPassword);
const browserSide = await browserPage(args, { width: 1280, height: 800 });
const { browser, page, problems, step } = browserSide;
const shot = (name) => page.screenshot({ path: path.join(out, `${name}.png`), fullPage: true, animations: 'disabled' });

// What the page checks found, said all at once at the end of the step that looked (one run names
// every page's faults).
const found = [];
function report(ok, what) { if (!ok) found.push(what); }
function reported() {
  const all = found.splice(0);
  check(all.length === 0, all.join('\n'));
}

// axe-core on the page as it stands: every serious or critical violation, named with where it is.
const audited = [];
async function audit(what) {
  const axe = await axeFindings(page);
  audited.push(`${what} (${axe.all.length ? axe.all.join(', ') : 'nothing'})`);
  report(axe.serious.length === 0, `${what} (${page.url()}): axe finds\n` + axe.serious.join('\n'));
}

// Drops the problems seen that are answers the page expects and handles.
function forget(expected) {
  problems.splice(0, problems.length, ...problems.filter((p) => !expected.test(p)));
}

// Opens a page and waits until its data has come (no request for half a second, or 5 s at most:
// the live pages ask every second).
async function open(p, ready) {
  await page.goto(base + '/' + p);
  if (ready) await page.waitForSelector(ready, { state: 'attached' });
  await page.waitForLoadState('networkidle', { timeout: 5000 }).catch(() => {});
}

// Logs in on the login page as it stands; freshLogIn first ends this browser's login.
async function logIn(username, password, landing) {
  await page.fill('#username', username);
  await page.fill('#password', password);
  await page.press('#password', 'Enter');
  await page.waitForURL(landing);
}
async function freshLogIn(username, password, landing) {
  await page.evaluate(() => localStorage.clear());
  await open('index.html', '#login');
  await logIn(username, password, landing);
}

// Tab from wherever the focus is until `selector` has it: the control is in the tab order. Fails
// after `max` presses.
async function tabTo(selector, max = 80) {
  for (let i = 0; i < max; i++) {
    if (await page.evaluate((s) => document.activeElement && document.activeElement.matches(s), selector)) return;
    await page.keyboard.press('Tab');
  }
  const at = await page.evaluate(() => document.activeElement ? document.activeElement.outerHTML.slice(0, 120) : 'nothing');
  throw new Error(`${selector} is not reached by Tab in ${max} presses (the focus is on ${at})`);
}

// Every visible field is wide enough for what it shows: its value, else its placeholder, or a
// list's chosen option, measured in the field's own font (a number's spinner, a search's clear
// button and a list's arrow given their room).
async function noFieldCutsItsText(what) {
  const cut = await page.$$eval('input:not([type=hidden]):not([type=checkbox]):not([type=radio]):not([type=range]), select', (xs) => xs
    .filter((x) => x.offsetParent !== null)
    .map((x) => {
      const select = x.tagName === 'SELECT';
      const text = select ? (x.selectedOptions[0] ? x.selectedOptions[0].textContent : '') : (x.value || x.placeholder || '');
      const cs = getComputedStyle(x);
      const probe = document.createElement('span');
      probe.style.cssText = `position:absolute;visibility:hidden;white-space:pre;font:${cs.font};letter-spacing:${cs.letterSpacing}`;
      probe.textContent = text;
      document.body.append(probe);
      const extra = select ? 20 : x.type === 'number' ? 16 : x.type === 'search' && x.value ? 16 : 0;
      const need = probe.getBoundingClientRect().width + parseFloat(cs.paddingLeft) + parseFloat(cs.paddingRight) + extra;
      probe.remove();
      const have = x.getBoundingClientRect().width - parseFloat(cs.borderLeftWidth) - parseFloat(cs.borderRightWidth);
      return { field: x.id || x.name || x.outerHTML.slice(0, 60), text, need: Math.ceil(need), have: Math.floor(have) };
    })
    .filter((f) => f.text && f.need > f.have + 1));
  report(cut.length === 0, `${what}: fields cut their text:\n` + cut.map((f) => `  ${f.field}: "${f.text}" needs ${f.need} px, has ${f.have}`).join('\n'));
}

try {
  await waitForServer(base, procs, server);
  const { token: admin, user_id: adminId } = await api('POST', '/login', null, { username: 'admin', password: adminPassword });
  await api('POST', '/users', admin, { username: 'ines', password: 'ines-pass-1', role: 'instructor', full_name: 'Ines Instructor' });
  const pupil = await api('POST', '/pupils', admin, { name: 'Kay Keyboard', email: 'kay.keyboard@example.org', username: 'kay', password: 'kay-pass-12' });
  const cab = 'keycab';
  let sessionId;

  await step('keyboard only: the instructor logs in with Tab, typing and Enter', async () => {
    await page.goto(base + '/');
    await tabTo('#username');
    await page.keyboard.type('ines');
    await tabTo('#password');
    await page.keyboard.type('ines-pass-1');
    await page.keyboard.press('Enter');
    await page.waitForURL(/fleet\.html$/);
  });

  await step('keyboard only: to the start page from the top bar, a session started', async () => {
    await tabTo('#top a[href="start.html"]');
    await page.keyboard.press('Enter');
    await page.waitForURL(/start\.html$/);
    await page.waitForSelector('#scenario option', { state: 'attached' });
    await tabTo('#pupil-search');
    await page.keyboard.type('Kay Keyboard');
    await page.waitForFunction(() => document.getElementById('pupil').value !== '');
    // The scenario by typing its first letters into the list, as a keyboard picks from one.
    await tabTo('#scenario');
    await page.keyboard.type('first_drive_yard');
    check(await page.inputValue('#scenario') === 'first_drive_yard', `the scenario chosen by typing: ${await page.inputValue('#scenario')}`);
    await tabTo('#cab');
    await page.keyboard.type(cab);
    await tabTo('#limit');
    await page.keyboard.type('20');
    await noFieldCutsItsText('the start page, filled in');
    reported();
    await tabTo('#start-button');
    await page.keyboard.press('Space');
    await page.waitForSelector('#started:not([hidden])');
    sessionId = new URL(await page.getAttribute('#started-link', 'href'), base).searchParams.get('id');
    check(sessionId, 'the session started');
    procs.start('cab', path.join(args.bin, 'forklift-cab'),
      ['--cab', cab, '--script', path.join(args.data, 'evaluation', 'scripts', 'first_drive_yard_faults.csv'),
       '--dds-domain', String(domain), '--wait-worker', '60', ...(supports(path.join(args.bin, 'forklift-cab'), '--no-window') ? ['--no-window'] : [])]);
  });

  await step('keyboard only: the session opened from the start page, live, then its debrief', async () => {
    await tabTo('#started-link');
    await page.keyboard.press('Enter');
    await page.waitForURL(/session\.html\?id=/);
    let s;
    for (let i = 0; i < 1200; i++) {
      s = await api('GET', `/sessions/${sessionId}`, admin);
      if (['ended', 'failed', 'aborted'].includes(s.state)) break;
      await sleep(100);
    }
    check(s.state === 'ended', `the session ended: ${s.state} ${s.reason}\n${procs.tail('cab')}`);
    check(s.events.length > 0, 'the faulty drive has events');
    // Its log reaches the store a moment after the end (503 until then).
    for (let i = 0; ; i++) {
      const r = await fetch(`${base}/api/sessions/${sessionId}/replay`, { headers: { Authorization: `Bearer ${admin}` } });
      if (r.ok) break;
      check(r.status === 503 && i < 300, `the replay: ${r.status} ${await r.text()}`);
      await sleep(200);
    }
    // Open through the end, the page heard the session was over from its live view's 409 and
    // waited out the replay's 503 (not ready): answers it handles, not faults.
    forget(/(HTTP 409 for GET .*\/live$|HTTP 503 for GET .*\/replay$|status of (409|503) )/);
    await page.keyboard.press('F5');
    await page.waitForSelector('#replay[data-ready=true]', { timeout: 240000 });
    await page.waitForSelector('#sign-off-form:not([hidden])');
    // How it ended, in words: the state and the worker's end reason, never a code such as time_limit.
    const facts = (await page.textContent('#facts')).replace(/first_drive_yard/g, '');
    check(/ended \((the time limit was reached|its time was up)\)/.test(facts) && !/\b[a-z]+_[a-z_]+\b/.test(facts),
          `the session's facts in words: ${facts}`);
    await audit('the debrief');
    reported();
  });

  await step('colour is never the only signal: each event and each level of the marking sheet in words', async () => {
    // Each item's badge says its level: its colour is not alone.
    const said = (rows) => rows.map((row) => ({ text: row.textContent.slice(0, 80),
      level: [...row.querySelectorAll('span, strong, em')].map((x) => x.textContent.trim())
        .find((t) => ['information', 'minor', 'medium', 'serious'].includes(t)) }));
    const events = await page.$$eval('#timeline li[data-seq]', said);
    check(events.length > 0, 'events listed');
    for (const e of events) check(e.level, `an event says its worry level in words: ${e.text}`);
    const sheet = await page.$$eval('#sheet tbody tr', said);
    check(sheet.some((r) => r.level), 'the marking sheet says its levels in words');
  });

  await step('keyboard only: a note and the sign-off', async () => {
    await tabTo('#note-text');
    await page.keyboard.type('Check behind before reversing.');
    await tabTo('#note-form button[type=submit]');
    await page.keyboard.press('Enter');
    await page.waitForSelector('#notes li[data-note]');
    await tabTo('#sign-off-comment');
    await page.keyboard.type('Signed off by keyboard alone.');
    await tabTo('#sign-off-form button[type=submit]');
    await page.keyboard.press('Space');
    await page.waitForSelector('#signed-off:not([hidden])');
    check((await page.textContent('#signed-off')).includes('Signed off by keyboard alone.'), 'the sign-off is kept');
    await audit('the debrief, signed off');
    reported();
    await shot('debrief-signed-off');
  });

  // A session with no cab: it waits live for its cab (aborted at the end).
  const waiting = await api('POST', '/sessions', admin, { pupil_id: pupil.id, cab_id: 'nocab', scenario: 'first_drive_yard' });

  await step('axe: the staff pages, as the administrator', async () => {
    await page.evaluate(() => localStorage.clear());
    await open('index.html', '#login');
    await audit('the login page');
    // axe is looking: an image with no text and a button with no name put on the page are found.
    const seen = await page.evaluate(async () => {
      document.getElementById('main').insertAdjacentHTML('beforeend', '<img src="data:," id="no-alt"><button id="no-name"></button>');
      const r = await window.axe.run(document, { resultTypes: ['violations'] });
      document.getElementById('no-alt').remove();
      document.getElementById('no-name').remove();
      return r.violations.filter((v) => v.impact === 'critical').map((v) => v.id);
    });
    check(seen.includes('image-alt') && seen.includes('button-name'), `axe finds an image without alt and a button without a name: ${seen}`);
    await page.fill('#username', 'admin');
    await page.fill('#password', adminPassword);
    await page.press('#password', 'Enter');
    await page.waitForURL(/fleet\.html$/);
    for (const [p, what, ready] of staffPages()) {
      await open(p, ready);
      await audit(what);
      await noFieldCutsItsText(what);
      await shot(`a11y-${p.replace(/[^a-z]+/g, '-')}`);
    }
    reported();
  });

  // The staff pages, as the administrator sees them.
  function staffPages() {
    return [
      ['fleet.html', 'the fleet', null], ['day.html', 'the day', null], ['pupils.html', 'the pupils', '#pupils tbody tr'],
      [`pupil.html?id=${pupil.id}`, "a pupil's record", null], ['start.html', 'the start page', '#scenario option'],
      ['sessions.html', 'the sessions', null], [`session.html?id=${waiting.id}`, 'a session live, waiting for its cab', '#live:not([hidden])'],
      [`session.html?id=${sessionId}`, "a finished session's debrief", '#replay[data-ready=true]'],
      ['exams.html', 'the exams', null], ['staff.html', 'the staff', null], ['theory.html', 'the theory exam, for staff', null],
      ['verify.html', 'the certificate check', null],
    ];
  }

  await step('axe: the pupil\'s own pages: record, theory paper, certificate', async () => {
    await freshLogIn('kay', 'kay-pass-12', /pupil\.html/);
    await page.waitForLoadState('networkidle', { timeout: 5000 }).catch(() => {});
    await audit("the pupil's own record");
    await open('theory.html', '#intro:not([hidden])');
    await audit('the theory exam page, for the pupil');
    if (await page.isVisible('#begin-practice')) {
      await page.click('#begin-practice');
      await page.waitForSelector('#paper:not([hidden]), form:not([hidden]) fieldset');
      await audit('the theory paper');
      await shot('a11y-theory-paper');
    }
    await open(`certificate.html?pupil=${pupil.id}`, null);
    // No licence yet: the API's 409 is how the page hears it, and says so.
    forget(/(HTTP 409 for GET .*\/certificate$|status of 409 )/);
    await audit("the pupil's certificate page");
    reported();
  });


  // Spanish: the administrator and the pupil choose it with the top bar's selector (their own
  // record, PATCHed), and every page they see is worded in it: no English message of the
  // catalogues left (names and codes stay as they are), and axe as clean as in English.
  const english = englishMessages(args.data);
  // What stays as it was given: people's names, cabs, scenarios' codes, the notes typed above.
  const names = ['Kay Keyboard', 'kay', 'admin', 'ines', 'Ines Instructor', cab, 'nocab', 'Check behind before reversing.',
                 'Signed off by keyboard alone.', ...(await api('GET', '/scenarios', admin)).map((x) => x.name)];
  async function inSpanish(what) {
    check(await page.getAttribute('html', 'lang') === 'es', `${what} says it is Spanish`);
    const left = await englishLeft(page, english, names);
    report(left.length === 0, `${what} (${page.url()}) in Spanish still shows English: ${JSON.stringify(left)}`);
    await audit(`${what}, in Spanish`);
  }
  async function chooseSpanish(landing) {
    await page.selectOption('#language', 'es');
    await page.waitForURL(landing);
    await page.waitForFunction(() => document.documentElement.lang === 'es');
  }

  await step('Spanish: the administrator chooses it, and every staff page is in it', async () => {
    await page.evaluate(() => localStorage.clear());
    await open('index.html?lang=es', '#login');
    await inSpanish('the login page');
    await logIn('admin', adminPassword, /fleet\.html$/);
    check(await page.getAttribute('html', 'lang') === 'en', 'the administrator reads English until she chooses');
    await chooseSpanish(/fleet\.html$/);
    check((await api('GET', `/users/${adminId}`, admin)).language === 'es', 'her choice is kept on her account');
    for (const [p, what, ready] of staffPages()) {
      await open(p, ready);
      await inSpanish(what);
      if (p === `session.html?id=${sessionId}`) await shot('a11y-es-debrief');
    }
    reported();
  });

  await step("Spanish: the pupil chooses it, and his own pages are in it", async () => {
    await freshLogIn('kay', 'kay-pass-12', /pupil\.html/);
    await chooseSpanish(/pupil\.html/);
    check((await api('GET', `/pupils/${pupil.id}`, admin)).language === 'es', 'his choice is kept on his record');
    await page.waitForLoadState('networkidle', { timeout: 5000 }).catch(() => {});
    await inSpanish("the pupil's own record");
    await open('theory.html', '#intro:not([hidden])');
    await inSpanish('the theory exam page, for the pupil');
    await open(`certificate.html?pupil=${pupil.id}`, null);
    forget(/(HTTP 409 for GET .*\/certificate$|status of 409 )/);
    await inSpanish("the pupil's certificate page");
    reported();
    // Back to English for whoever runs after.
    await api('PATCH', `/pupils/${pupil.id}`, admin, { language: 'en' });
  });

  await step('the certificate check, public, for a number no certificate has', async () => {
    await page.evaluate(() => localStorage.clear());
    await open('verify.html?number=FS-0000-0000', null);
    // "not found" is the page's answer, the API's 404 its way of giving it.
    forget(/(HTTP 404 for GET .*\/api\/certificates\/|status of 404 )/);
    await audit('the certificate check, not found');
    reported();
    await api('POST', `/sessions/${waiting.id}/abort`, admin);
  });

  console.log(`a11y: all steps passed; axe on ${audited.length} pages, what it found of any impact:\n  ${audited.join('\n  ')}`);
  await browser.close();
  await procs.stopAll();
  process.exit(0);
} catch (e) {
  await failed(e, { ...browserSide, out, procs, logs: procs.tail('server') });
}
