// The school's lists in a browser, against a real forklift-server on
// loopback with 600 pupils added through its API, and a day of sessions and an exam written
// straight into its SQLite file (no truck is driven: that is web_e2e's work):
//   the pupils page a page at a time with the total, paged, sorted, searched by email, the CSV of
//   the whole filtered list (every page of it) downloaded and read back, the add form on screen
//   without scrolling -> the start page's type-ahead pupil picker and its word on an unknown cab
//   -> the sessions page (today's by default, filtered by cab and result, its CSV) -> the exams
//   list -> the day view: a cab booked, a double booking refused, the day's grid with the booking
//   and the sessions run, every cell whole at 1280x800, names in full, outcomes in words, open at
//   the current hour.
//
//   BUILD/tests/forklift-test-alloc node lists.mjs --bin BUILD/bin --data data
//                [--chromium /usr/bin/chromium] [--out DIR] [--headed]
//
// forklift-test-alloc passes the port (FORKLIFT_TEST_PORT) and DDS domain (FORKLIFT_TEST_DOMAIN)
// it holds from the tests' allocator (tests/support/ports.h).
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';
import { setup, check, Processes, apiOf, waitForServer } from './harness.mjs';

const { args, domain, out, base } = setup('web-lists');
const procs = new Processes(out);
const api = apiOf(base);

// ---------------------------------------------------------------- the server
const adminPassword = 'lists-admin-pass';
const db = path.join(out, 'forklift.db');
const server = procs.start('server', path.join(args.bin, 'forklift-server'),
  ['--db', db, '--listen', base.replace('http://', ''), '--dds-domain', String(domain), '--admin-password', adminPassword,
   '--log-dir', path.join(out, 'logs')]);

// A CSV file's rows as cells (RFC 4180 quoting).
function csvRows(text) {
  const rows = [];
  let row = [], cell = '', quoted = false;
  for (let i = 0; i < text.length; i++) {
    const c = text[i];
    if (quoted) {
      if (c === '"' && text[i + 1] === '"') { cell += '"'; i++; } else if (c === '"') quoted = false; else cell += c;
    } else if (c === '"') quoted = true;
    else if (c === ',') { row.push(cell); cell = ''; } else if (c === '\n') { row.push(cell.replace(/\r$/, '')); rows.push(row); row = []; cell = ''; } else cell += c;
  }
  if (cell || row.length) { row.push(cell); rows.push(row); }
  return rows;
}

const pad = (n) => String(n).padStart(3, '0');
const today = new Date().toISOString().slice(0, 10);
const yesterday = new Date(Date.now() - 86400e3).toISOString().slice(0, 10);

let browser;
let failed = false;
try {
  await waitForServer(base, procs, server);
  const admin = (await api('POST', '/login', null, { username: 'admin', password: adminPassword })).token;

  // 600 pupils through the API, a few at a time (SQLite takes one writer at a time: more in flight
  // only wait on its lock); every tenth with a depot address.
  const t0 = Date.now();
  const email = (i) => (i % 10 === 0 ? `driver${pad(i)}@depot.example` : `pupil${pad(i)}@school.example`);
  const ids = [];
  for (let first = 0; first < 600; first += 3) {
    const batch = [];
    for (let i = first; i < first + 3; i++) batch.push(api('POST', '/pupils', admin, { name: `Pupil ${pad(i)}`, email: email(i) }));
    for (const p of await Promise.all(batch)) ids.push(p.id);
  }
  console.log(`600 pupils added through the API in ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  await api('POST', '/users', admin, { username: 'ines', password: 'ines-pass-1', role: 'instructor', full_name: 'Ines Instructor' });
  const ines = (await api('GET', '/users?role=instructor', admin)).users[0].id;
  const group = await api('POST', '/groups', admin, { name: 'Morning course', instructor_id: ines });
  for (const id of ids.slice(0, 5)) await api('PUT', `/pupils/${id}/group`, admin, { group_id: group.id });

  // Today's sessions (12, on two cabs, half of them passed, the last stopped by its time limit),
  // yesterday's one, and a theory exam, as the server would have written them (each session's
  // outcome with it, and each row's school, as the store keeps them).
  const school = execFileSync('sqlite3', [db, `SELECT school_id FROM pupils WHERE id = ${ids[0]};`], { encoding: 'utf8' }).trim();
  const rows = [];
  for (let i = 0; i < 12; i++) {
    const at = `${today}T${String(7 + i).padStart(2, '0')}:00:00Z`;
    rows.push(`(${ids[i]}, 'cab${1 + (i % 2)}', 'manoeuvre_4', 'training', 'ended', '${i === 11 ? 'time_limit' : 'task_complete'}', '${at}', '${at}', ${60 + i}.25, ${i % 4 < 2 ? 1 : 0}, ${ines}, ${school}, '${i === 11 ? 'timed_out' : 'completed'}')`);
  }
  rows.push(`(${ids[20]}, 'cab1', 'manoeuvre_4', 'training', 'ended', 'task_complete', '${yesterday}T09:00:00Z', '${yesterday}T09:10:00Z', 70, 1, ${ines}, ${school}, 'completed')`);
  execFileSync('sqlite3', [db, `.timeout 5000`,
    'INSERT INTO sessions (pupil_id, cab_id, scenario, mode, state, reason, created_at, ended_at, mark, passed, started_by, school_id, outcome) VALUES ' +
    rows.join(', ') + ';',
    `INSERT INTO exams (pupil_id, kind, score, passed, taken_at, details, school_id) VALUES (${ids[3]}, 'theory', 0.875, 1, '${today}T12:00:00Z', '{}', ${school});`]);

  // ---------------------------------------------------------------- the browser
  browser = await chromium.launch({ executablePath: args.chromium, headless: !args.headed });
  const context = await browser.newContext({ viewport: { width: 1280, height: 860 }, locale: 'en-GB', timezoneId: 'UTC', acceptDownloads: true });
  const page = await context.newPage();
  page.setDefaultTimeout(15000);
  const problems = [];
  let allowed = [];  // HTTP errors a step expects (a double booking's 409)
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => { if (m.type() === 'error' && !allowed.some((s) => m.text().includes(String(s)))) problems.push(`console error: ${m.text()}`); });
  page.on('response', (r) => { if (r.status() >= 400 && !allowed.includes(r.status())) problems.push(`HTTP ${r.status()} for ${r.request().method()} ${r.url()}`); });

  let stepNo = 0;
  const step = async (name, fn) => {
    const t = Date.now();
    process.stdout.write(`${++stepNo}. ${name} ... `);
    await fn();
    check(problems.length === 0, problems.join('\n'));
    console.log(`ok (${((Date.now() - t) / 1000).toFixed(1)} s)`);
  };
  const count = () => page.textContent('#count');
  const waitCount = (text) => page.waitForFunction((t) => document.getElementById('count').textContent.includes(t), text);
  const download = async (button) => {
    const [d] = await Promise.all([page.waitForEvent('download'), page.click(button)]);
    return csvRows(fs.readFileSync(await d.path(), 'utf8'));
  };

  await step('log in', async () => {
    await page.goto(base + '/');
    await page.fill('#username', 'admin');
    await page.fill('#password', adminPassword);
    await page.click('#login button[type=submit]');
    await page.waitForURL(/fleet\.html$/);
  });

  await step('the pupils page: the total, a page at a time, the add form without scrolling', async () => {
    await page.click('#top a[href="pupils.html"]');
    await waitCount('of 600 pupils');
    check((await count()).startsWith('1–50 of 600'), `the first page and the total: ${await count()}`);
    check(await page.locator('#pupils tbody tr').count() === 50, 'a page has 50 pupils');
    const add = await page.locator('#add button[type=submit]').boundingBox();
    check(add && add.y + add.height <= 860 && await page.evaluate(() => window.scrollY) === 0,
          `the add form's button is on the first screen: ${JSON.stringify(add)}`);
    // "Next" asks for the page after the last row shown (keyset paging), not an offset.
    const keyset = page.waitForRequest((r) => r.url().includes('/api/pupils?') && /[?&]after=\d+/.test(r.url()), { timeout: 10000 });
    await page.click('#next');
    await keyset;
    await waitCount('51–100 of 600');
    check((await page.textContent('#pupils tbody tr:first-child th')) === 'Pupil 050', 'the second page starts at Pupil 050');
    await page.click('#previous');
    await waitCount('1–50 of 600');
    // Sorted by a column: by name, backwards.
    await page.click('#pupils thead th[data-sort="name"] button');
    await page.waitForFunction(() => document.querySelector('#pupils tbody tr:first-child th').textContent === 'Pupil 599');
    check(await page.getAttribute('#pupils thead th[data-sort="name"]', 'aria-sort') === 'descending', 'the header says the order');
  });

  await step('search by email, and the CSV of that whole list, every page of it', async () => {
    await page.fill('#search', 'depot.example');
    await waitCount('of 60 pupils');
    await page.click('#pupils thead th[data-sort="email"] button');
    await page.waitForFunction(() => document.querySelector('#pupils tbody tr:first-child td').textContent === 'driver000@depot.example');
    await page.click('#next');
    await waitCount('51–60 of 60');
    const shown = await page.$$eval('#pupils tbody tr', (trs) => trs.map((tr) => [tr.querySelector('th').textContent, tr.querySelector('td').textContent]));
    const csv = await download('#csv');
    check(csv[0].join(',') === 'id,name,email,group,instructor,added', `the CSV's header: ${csv[0]}`);
    check(csv.length === 1 + 60 && shown.length === 10, `the CSV has the filter's 60 rows, not the page's ${shown.length}: ${csv.length - 1}`);
    shown.forEach(([name, mail], i) => check(csv[i + 51][1] === name && csv[i + 51][2] === mail, `CSV row ${i + 51} is ${name}: ${csv[i + 51]}`));
    check(csv.slice(1).every((r) => r[2].endsWith('@depot.example')), 'only the filtered pupils');
  });

  await step('add a pupil with the form at the top, into a group', async () => {
    await page.fill('#search', '');
    await waitCount('of 600 pupils');
    const all = await download('#csv');
    check(all.length === 1 + 600 && new Set(all.slice(1).map((r) => r[0])).size === 600,
          `the whole list's CSV has its 600 pupils once each, streamed past the server's batches: ${all.length - 1}`);
    await page.fill('#name', 'Zed Newcomer');
    await page.fill('#email', 'zed@depot.example');
    await page.selectOption('#new-group', String(group.id));
    await page.click('#add button[type=submit]');
    await page.waitForSelector('#added-pupil');
    await waitCount('of 601 pupils');
    await page.selectOption('#filter-group', String(group.id));
    await waitCount('of 6 pupils');
    check((await page.textContent('#pupils tbody')).includes('Zed Newcomer'), 'the new pupil is in the group');
    check((await page.textContent('#pupils tbody')).includes('Ines Instructor'), 'with its instructor');
  });

  await step('the start page picks a pupil by typing, and says when a cab is unknown', async () => {
    await page.goto(`${base}/start.html`);
    await page.waitForSelector('#scenario option', { state: 'attached' });
    await page.fill('#pupil-search', 'driver120');
    await page.waitForFunction(() => document.querySelectorAll('#pupil-options option').length === 1);
    const option = await page.getAttribute('#pupil-options option', 'value');
    check(option.startsWith('Pupil 120'), `the match: ${option}`);
    await page.fill('#pupil-search', option);
    await page.waitForFunction((id) => document.getElementById('pupil').value === String(id), ids[120]);
    await page.fill('#cab', 'cabb1');
    await page.dispatchEvent('#cab', 'change');
    check((await page.textContent('#cab-warning')).includes('cabb1'), 'a cab no one has seen is pointed out');
    const opened = await page.goto(`${base}/start.html?pupil=${ids[7]}`);
    check(opened.ok(), 'the page opens for a pupil');
    await page.waitForFunction((id) => document.getElementById('pupil').value === String(id), ids[7]);
  });

  await step("the sessions page: today's, by cab and result, and its CSV", async () => {
    await page.goto(`${base}/sessions.html`);
    await waitCount('of 12 sessions');
    await page.fill('#cab', 'cab1');
    await page.dispatchEvent('#cab', 'change');
    await waitCount('of 6 sessions');
    await page.selectOption('#result', 'passed');
    await waitCount('of 3 sessions');
    const shown = await page.$$eval('#sessions tbody tr', (trs) => trs.map((tr) => tr.dataset.session));
    const csv = await download('#csv');
    check(csv.length === 4 && csv.slice(1).map((r) => r[0]).join() === shown.join(), `the CSV is the list shown: ${csv.map((r) => r[0])} vs ${shown}`);
    check(csv.slice(1).every((r) => r[3] === 'cab1' && r[9] === 'yes' && /^\d+\.\d$/.test(r[8]) && r[6] === 'Ines Instructor'),
          `cab1, passed, marks to one decimal, by name: ${JSON.stringify(csv)}`);
    await page.fill('#date', yesterday);
    await page.dispatchEvent('#date', 'change');
    await waitCount('of 1 session');
  });

  await step('the exams list', async () => {
    await page.click('#top a[href="exams.html"]');
    await waitCount('of 1 exam');
    check((await page.textContent('#exams tbody')).includes('87.5 %'), 'the theory score as a percentage');
    const csv = await download('#csv');
    check(csv[1][6] === '87.5' && csv[1][5] === '', `theory in its own column: ${csv[1]}`);
  });

  await step('the day view: a cab booked, a double booking refused, the day by cab', async () => {
    await page.click('#top a[href="day.html"]');
    await page.waitForFunction(() => document.getElementById('summary').textContent.includes('12 sessions run'));
    await page.click('#book-heading');
    await page.fill('#pupil-search', 'pupil007');
    await page.waitForFunction(() => document.querySelectorAll('#pupil-options option').length === 1);
    await page.fill('#pupil-search', await page.getAttribute('#pupil-options option', 'value'));
    await page.waitForFunction((id) => document.getElementById('pupil').value === String(id), ids[7]);
    await page.fill('#cab', 'cab1');
    await page.fill('#start', '15:00');
    await page.fill('#minutes', '60');
    await page.click('#book button[type=submit]');
    await page.waitForSelector('#message .ok');
    await page.waitForSelector('#grid td[data-cab="cab1"] .booking');
    check((await page.textContent('#grid td[data-cab="cab1"] .booking')).includes('Pupil 007'), 'the booking is on the grid');
    allowed = [409];
    await page.fill('#start', '15:30');
    await page.click('#book button[type=submit]');
    await page.waitForSelector('#message .error');
    check((await page.textContent('#message')).includes('already booked'), `the clash said in words: ${await page.textContent('#message')}`);
    check(!/\([a-z]+(_[a-z]+)*\)\s*$/.test(await page.textContent('#message')), `no API code after the words: ${await page.textContent('#message')}`);
    allowed = [];
    check(await page.locator('#grid td[data-cab="cab2"] .ran').count() === 6, 'the sessions run on cab2');
  });

  await step('the day fits 1280x800: no cell cut, names in full, outcomes in words, open at the current hour', async () => {
    await page.setViewportSize({ width: 1280, height: 800 });
    await page.reload();
    await page.waitForFunction(() => document.getElementById('summary').textContent.includes('12 sessions run'));
    const seen = await page.evaluate(() => {
      const width = document.documentElement.clientWidth;
      const cut = [];
      for (const c of document.querySelectorAll('#grid th, #grid td, #grid .booking, #grid .ran')) {
        const r = c.getBoundingClientRect();
        if (r.left < 0 || r.right > width + 0.5 || c.scrollWidth > c.clientWidth + 1) cut.push(`${c.tagName} ${c.textContent.slice(0, 40)} ${JSON.stringify(r)}`);
      }
      const box = document.querySelector('.day').getBoundingClientRect(), now = document.querySelector('#grid tr.now');
      const row = now && now.getBoundingClientRect();
      return { cut, pageWidth: document.documentElement.scrollWidth, width, now: now && now.textContent,
               nowShown: !!row && row.top >= box.top - 1 && row.top < box.bottom && row.top < window.innerHeight,
               ran: [...document.querySelectorAll('#grid .ran')].map((r) => ({ text: r.textContent, title: r.title, outcome: r.dataset.outcome })) };
    });
    check(seen.cut.length === 0, `no cell cut or past the page's edge: ${seen.cut.join('\n')}`);
    check(seen.pageWidth <= seen.width, `no sideways scroll: ${seen.pageWidth} px of ${seen.width}`);
    check(seen.nowShown, `the current hour's row is on screen: ${seen.now}`);
    check(seen.ran.length === 12 && seen.ran.every((r) => /Pupil \d{3}/.test(r.text) && r.title.includes(r.text.match(/Pupil \d{3}/)[0])),
          `names in full, and in the tooltip: ${JSON.stringify(seen.ran.slice(0, 2))}`);
    check(seen.ran.every((r) => !/timed_out|\bopen\b|_out/.test(r.text)), `no outcome codes: ${seen.ran.map((r) => r.text)}`);
    const late = seen.ran.find((r) => r.outcome === 'timed_out');
    check(late && late.text.endsWith(': out of time'), `the time limit's end in words: ${late && late.text}`);
    await page.setViewportSize({ width: 1280, height: 860 });
  });
} catch (e) {
  failed = true;
  console.log(`FAILED\n${e.stack || e}`);
  try { console.log(fs.readFileSync(path.join(out, 'server.log'), 'utf8').split('\n').slice(-20).join('\n')); } catch (x) { /* none */ }
} finally {
  if (browser) await browser.close();
  await procs.stopAll();
}
process.exit(failed ? 1 : 0);
