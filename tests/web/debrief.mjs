// The debrief in the browser, against a real forklift-server, worker and cab:
// a pupil drives the yard with faults; the instructor opens the finished session, whose replay is
// re-simulated from its control log; at three events the replay shows the truck where and when
// the event happened; the events read in words and units; the plan zooms; a note and the
// sign-off are kept and audited, and the note is on the pupil's record.
//
//   BUILD/tests/forklift-test-alloc node debrief.mjs --bin BUILD/bin --data data [--out DIR] [--headed]
import path from 'node:path';
import { setup, startServer, check, sleep, supports, Processes, apiOf, waitForServer, browserPage } from './harness.mjs';

const test = setup('debrief');
const { args, domain, out, base } = test;
const procs = new Processes(out);
const api = apiOf(base);
const adminPassword = 'web-admin-pass';
const server = startServer(procs, test, adminPassword);
const { browser, page, problems, step } = await browserPage(args);
const shot = (name) => page.screenshot({ path: path.join(out, `${name}.png`), fullPage: true, animations: 'disabled' });

// The replay's centre of gravity at time t, as the page interpolates it.
function replayAt(samples, t) {
  if (t <= samples[0].t) return samples[0];
  for (let i = 1; i < samples.length; i++) {
    const a = samples[i - 1], b = samples[i];
    if (b.t < t) continue;
    const f = (t - a.t) / (b.t - a.t);
    return { t, x_m: a.x_m + f * (b.x_m - a.x_m), y_m: a.y_m + f * (b.y_m - a.y_m) };
  }
  return samples[samples.length - 1];
}

let failed = false;
try {
  await waitForServer(base, procs, server);
  const admin = (await api('POST', '/login', null, { username: 'admin', password: adminPassword })).token;
  await api('POST', '/users', admin, { username: 'ines', password: 'ines-pass-1', role: 'instructor', full_name: 'Ines Instructor' });
  const ines = (await api('POST', '/login', null, { username: 'ines', password: 'ines-pass-1' })).token;
  const pupil = await api('POST', '/pupils', admin, { name: 'Dan Driver' });
  let session;

  await step('a pupil drives the yard with faults, and the session ends', async () => {
    session = await api('POST', '/sessions', ines, { pupil_id: pupil.id, cab_id: 'debriefcab', scenario: 'first_drive_yard', time_limit_s: 23 });
    procs.start('cab', path.join(args.bin, 'forklift-cab'),
      ['--cab', 'debriefcab', '--script', path.join(args.data, 'evaluation', 'scripts', 'first_drive_yard_faults.csv'),
       '--dds-domain', String(domain), '--wait-worker', '60', ...(supports(path.join(args.bin, 'forklift-cab'), '--no-window') ? ['--no-window'] : [])]);
    for (let i = 0; i < 1200; i++) {
      session = await api('GET', `/sessions/${session.id}`, ines);
      if (['ended', 'failed', 'aborted'].includes(session.state)) break;
      await sleep(100);
    }
    check(session.state === 'ended', `the session ended: ${session.state} ${session.reason}\n${procs.tail('cab')}`);
    check(session.events.length >= 3, `at least three events: ${session.events.map((e) => e.kind)}`);
    // Its log reaches the store a moment after the end (503 not_ready until then): the page is
    // opened once the replay can be made, so that no error answer shows in the browser.
    for (let i = 0; ; i++) {
      const r = await fetch(`${base}/api/sessions/${session.id}/replay`, { headers: { Authorization: `Bearer ${ines}` } });
      if (r.ok) break;
      check(r.status === 503 && i < 300, `the replay: ${r.status} ${await r.text()}`);
      await sleep(200);
    }
  });

  await step('the instructor logs in and opens the session: its replay is made from the control log', async () => {
    await page.goto(base + '/');
    await page.fill('#username', 'ines');
    await page.fill('#password', 'ines-pass-1');
    await page.click('#login button[type=submit]');
    await page.waitForURL(/fleet\.html$/);
    await page.goto(`${base}/session.html?id=${session.id}`);
    await page.waitForSelector('#replay[data-ready=true]', { timeout: 240000 });
    await page.waitForSelector('#replay-truck');
  });

  await step('events read in words and units, not codes', async () => {
    const titles = await page.$$eval('#timeline li[data-seq] strong', (xs) => xs.map((x) => x.textContent));
    check(titles.length === session.events.length, `every event listed: ${titles.length}`);
    for (const t of titles) check(t && !t.includes('_'), `a title in words: ${t}`);
    const measured = await page.$$eval('#timeline .measured', (xs) => xs.map((x) => x.textContent));
    check(measured.length > 0, 'measured values shown');
    for (const m of measured) {
      check(/Measured: .*\d/.test(m) && !m.includes('_') && !/ m s /.test(m), `a measurement in units: ${m}`);
      check(/(m\/s|km\/h| cm| m\b|°| s\b| %| kg| N)/.test(m), `with its unit: ${m}`);
    }
    const sheet = await page.$$eval('#sheet tbody th', (xs) => xs.map((x) => x.textContent));
    for (const t of sheet) check(!t.includes('_'), `marking sheet in words: ${t}`);
  });

  await step('at three events the replay shows the truck where and when each happened', async () => {
    const replay = await api('GET', `/sessions/${session.id}/replay`, ines);
    const first = replay.samples[0].t, last = replay.samples[replay.samples.length - 1].t;
    const inside = session.events.filter((e) => e.sim_time_s >= first && e.sim_time_s <= last);
    check(inside.length >= 3, `three events inside the replay: ${inside.length}`);
    const chosen = [inside[0], inside[Math.floor(inside.length / 2)], inside[inside.length - 1]];
    for (const e of chosen) {
      await page.click(`#timeline li[data-seq="${e.seq}"] .show-event`);
      await page.waitForFunction((t) => Math.abs(Number(document.getElementById('replay-truck').dataset.t) - t) < 0.011, e.sim_time_s);
      const truck = await page.$eval('#replay-truck', (g) => ({ t: Number(g.dataset.t), x: Number(g.dataset.x), y: Number(g.dataset.y) }));
      const want = replayAt(replay.samples, e.sim_time_s);
      check(Math.hypot(truck.x - want.x_m, truck.y - want.y_m) < 0.01, `event ${e.seq}: the truck at the replay's state for t = ${e.sim_time_s}: ${JSON.stringify(truck)} vs ${JSON.stringify(want)}`);
      // Where the event happened: the truck's centre, or the point of a contact on its body.
      check(Math.hypot(truck.x - e.x_m, truck.y - e.y_m) < 4, `event ${e.seq} (${e.kind}) happened by the truck: ${JSON.stringify(truck)} vs (${e.x_m}, ${e.y_m})`);
      check(Math.abs(Number(await page.inputValue('#replay-time')) - e.sim_time_s) < 0.11, 'the time slider is at the event');
      check(await page.$eval(`#timeline li[data-seq="${e.seq}"]`, (li) => li.classList.contains('current')), 'the event is marked in the timeline');
    }
    // Playing moves the truck on, from the first of them.
    await page.click(`#timeline li[data-seq="${chosen[0].seq}"] .show-event`);
    const before = await page.$eval('#replay-truck', (g) => Number(g.dataset.t));
    await page.click('#replay-play');
    await page.waitForFunction((t0) => Number(document.getElementById('replay-truck').dataset.t) > t0 + 0.3, before);
    await page.click('#replay-play');
    check(await page.textContent('#replay-play') === 'Play', 'paused');
  });

  await step('the plan zooms, and the events stay apart and clickable', async () => {
    await page.click('#zoom-in');
    await page.click('#zoom-in');
    const zoom = Number(await page.getAttribute('#plan-svg', 'data-zoom'));
    check(zoom > 2, `zoomed in: ${zoom}`);
    // Zoomed, the view follows the truck through the replay.
    for (const e of session.events.slice(0, 3)) {
      await page.click(`#timeline li[data-seq="${e.seq}"] .show-event`);
      const seen = await page.evaluate(() => {
        const r = document.getElementById('plan-svg').getBoundingClientRect(), t = document.querySelector('#replay-truck circle').getBoundingClientRect();
        return t.left >= r.left && t.right <= r.right && t.top >= r.top && t.bottom <= r.bottom;
      });
      check(seen, `the truck in the zoomed view at event ${e.seq}`);
    }
    await shot('session-debrief-zoomed');
    await page.click('#zoom-reset');
    check(Number(await page.getAttribute('#plan-svg', 'data-zoom')) === 1, 'back to the whole plan');
  });

  await step('a note and the sign-off are kept and audited', async () => {
    await page.fill('#note-text', 'Look over your shoulder <b>before</b> reversing.');
    await page.click('#note-form button[type=submit]');
    await page.waitForSelector('#notes li[data-note]');
    check((await page.textContent('#notes li[data-note]')).includes('Look over your shoulder <b>before</b> reversing.'), 'the note, as typed');
    check((await page.textContent('#notes li[data-note]')).includes('Ines Instructor'), 'signed with the full name');
    await page.fill('#sign-off-comment', 'Ready to drive the yard alone.');
    await page.click('#sign-off-form button[type=submit]');
    await page.waitForSelector('#signed-off:not([hidden])');
    check(await page.isHidden('#note-form'), 'no more notes after the sign-off');
    await shot('session-debrief');
    await page.reload();
    await page.waitForSelector('#signed-off:not([hidden])');
    check((await page.textContent('#signed-off')).includes('Ready to drive the yard alone.'), 'the sign-off is kept');
    const audit = await api('GET', `/pupils/${pupil.id}/audit`, admin);
    const actions = audit.map((r) => r.action);
    check(actions.includes('session_note_added') && actions.includes('session_signed_off'), `audited: ${actions}`);
  });

  await step("the note is on the pupil's record, beside its session", async () => {
    await page.goto(`${base}/pupil.html?id=${pupil.id}`);
    const note = `#sessions tr[data-session="${session.id}"] td.notes li[data-note]`;
    await page.waitForSelector(note);
    const text = await page.textContent(note);
    check(text.includes('Look over your shoulder <b>before</b> reversing.') && text.includes('Ines Instructor'), `the note, by whom: ${text}`);
  });
  console.log(`debrief: all steps passed`);
} catch (e) {
  failed = true;
  console.error(`\nFAILED: ${e.stack || e}`);
  console.error(procs.tail('server'));
  try { await shot('failure'); } catch (err) { /* no page */ }
} finally {
  await browser.close();
  await procs.stopAll();
}
process.exit(failed || problems.length ? 1 : 0);
