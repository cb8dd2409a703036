// The people who move, seen from the instructor's page, against a real forklift-server, worker
// and scripted cab on the pedestrian_awareness course: the live plan draws the walkway's
// pedestrian where the worker's states put him, waiting for his cue; the instructor reaches
// "Start pedestrian W1 now" by Tab alone and starts him with Enter; the plan then shows him walking
// north along his path, and the hazard is audited. The pallet that falls and the spill, started
// from their buttons, then say they are down and cannot be started again. The live page with its hazard list passes
// axe-core. Once the session has ended, the debrief's replay draws him where the re-run has him,
// waiting before the hazard and walking after it.
//
//   BUILD/tests/forklift-test-alloc node pedestrians.mjs --bin BUILD/bin --data data [--out DIR] [--headed]
import fs from 'node:fs';
import path from 'node:path';
import { setup, startServer, axeFindings, check, sleep, supports, Processes, apiOf, waitForServer, browserPage, logInAs, failed } from './harness.mjs';

const test = setup('pedestrians');
const { args, domain, out, base } = test;
const procs = new Processes(out);
const api = apiOf(base);
const adminPassword = 'web-admin-pass';
const server = startServer(procs, test, adminPassword);
const side = await browserPage(args);
const { browser, page, problems, step } = side;
const shot = (name) => page.screenshot({ path: path.join(out, `${name}.png`), fullPage: true, animations: 'disabled' });

// The figure the plan draws for pedestrian `id`: what he is doing and where (world metres).
const figure = (id) => page.$eval(`#plan-svg g.person[data-pedestrian="${id}"]`,
  (g) => ({ activity: g.dataset.activity, x: Number(g.dataset.x), y: Number(g.dataset.y) }));

// Drops the problems seen that are answers the page expects and handles: the live view's 409 once
// the session is over, the replay's 503 while its log is on its way.
function forget(expected) {
  problems.splice(0, problems.length, ...problems.filter((p) => !expected.test(p)));
}

try {
  await waitForServer(base, procs, server);
  const admin = (await api('POST', '/login', null, { username: 'admin', password: adminPassword })).token;
  await api('POST', '/users', admin, { username: 'ines', password: 'ines-pass-1', role: 'instructor', full_name: 'Ines Instructor' });
  const ines = (await api('POST', '/login', null, { username: 'ines', password: 'ines-pass-1' })).token;
  const pupil = await api('POST', '/pupils', admin, { name: 'Walter Walkway' });
  let session;

  // The cab holds the truck on the brake at its start, 10 m from the walkway: the pedestrian's
  // trigger (the truck within 8 m) never fires, so he walks only when the instructor starts him.
  await step('a training session on the pedestrian course, the truck held at its start', async () => {
    const script = path.join(out, 'stand.csv');
    fs.writeFileSync(script, 't,steer,accelerator,brake,lift,tilt,shift\n0,0,0,0.3,0,0,0\n40,0,0,0.3,0,0,0\n');
    session = await api('POST', '/sessions', ines, { pupil_id: pupil.id, cab_id: 'walkcab', scenario: 'pedestrian_awareness', time_limit_s: 24 });
    procs.start('cab', path.join(args.bin, 'forklift-cab'),
      ['--cab', 'walkcab', '--script', script, '--dds-domain', String(domain), '--wait-worker', '60',
       ...(supports(path.join(args.bin, 'forklift-cab'), '--no-window') ? ['--no-window'] : [])]);
    for (let i = 0; i < 600; i++) {
      const v = await fetch(`${base}/api/sessions/${session.id}/live`, { headers: { Authorization: `Bearer ${ines}` } });
      if (v.ok && (await v.json()).state) break;
      await sleep(100);
    }
  });

  await step('the live plan draws the walkway pedestrian waiting for his cue, and his path', async () => {
    await page.goto(base + '/');
    await logInAs(page, 'ines', 'ines-pass-1', /fleet\.html$/);
    await page.goto(`${base}/session.html?id=${session.id}`);
    await page.waitForSelector('#plan-svg g.person[data-pedestrian="W1"][data-activity="waiting"]');
    const live = (await api('GET', `/sessions/${session.id}/live`, ines)).state;
    const w1 = live.pedestrians.find((p) => p.id === 'W1');
    const drawn = await figure('W1');
    check(Math.hypot(drawn.x - w1.x_m, drawn.y - w1.y_m) < 0.01 && Math.abs(drawn.y - 1.0) < 0.01,
          `drawn where the worker has him, at his path's first point: ${JSON.stringify(drawn)} vs ${JSON.stringify(w1)}`);
    check(await page.$('#plan-svg polyline[data-walk="W1"]') !== null, 'his path is on the plan');
    check(/W1 waiting/.test(await page.textContent('#live-people')), 'the live facts say he waits');
    await page.waitForSelector('#hazards:not([hidden]) li[data-pedestrian="W1"][data-activity="waiting"]');
    // The scenario's other hazards, the instructor's alone: the truck on aisle A (its route and
    // its box waiting at the start), the pallet that falls and the spill past the door, each
    // listed with words.
    check(await page.$('#plan-svg polygon[data-route="T1"]') !== null, "T1's route is on the plan");
    await page.waitForSelector('#plan-svg rect.other-truck[data-truck="T1"][data-activity="waiting"]');
    check(/Start truck T1 now/.test(await page.textContent('#hazard-list button[data-hazard="T1"]')), 'the truck is listed');
    check(/T1: waiting for its cue/.test(await page.textContent('li[data-hazard="T1"]')), 'in words');
    check(/Drop pallet P2 now/.test(await page.textContent('#hazard-list button[data-hazard="P2"]')), 'the falling pallet is listed');
    check(/Spill S1 now/.test(await page.textContent('#hazard-list button[data-hazard="S1"]')), 'the spill that waits is listed');
    check(/S1: a spill, not on the floor/.test(await page.textContent('li[data-hazard="S1"]')), 'in words');
    check(await page.getAttribute('#plan-svg rect.spill[data-spill="S1"]', 'data-on-floor') === 'false', 'the plan outlines the spill to come');
  });

  await step('the live page with its hazard list passes axe-core', async () => {
    const axe = await axeFindings(page);
    check(axe.serious.length === 0, 'axe finds\n' + axe.serious.join('\n'));
    await shot('session-live-pedestrian-waiting');
  });

  await step('keyboard only: Tab reaches "Start pedestrian W1 now" and Enter starts him', async () => {
    await page.focus('#pause');  // the instructor's first control: from there on, Tab only
    const button = '#hazard-list button[data-pedestrian="W1"]';
    let reached = false;
    for (let i = 0; i < 30 && !reached; i++) {
      await page.keyboard.press('Tab');
      reached = await page.evaluate((sel) => document.activeElement === document.querySelector(sel), button);
    }
    check(reached, 'the hazard button is in the tab order after the instructor\'s other controls');
    check(/Start pedestrian W1 now/.test(await page.textContent(button)), 'the button names him');
    await page.keyboard.press('Enter');
    await page.waitForSelector('#message:has-text("Pedestrian W1 steps out now.")');
    await page.waitForSelector('#plan-svg g.person[data-pedestrian="W1"][data-activity="walking"]');
    await page.waitForSelector('li[data-pedestrian="W1"][data-activity="walking"]');
    check(await page.getAttribute(button, 'aria-disabled') === 'true', 'a walking pedestrian cannot be started again');
    check(await page.evaluate((sel) => document.activeElement === document.querySelector(sel), button), 'the focus stays on the button');
  });

  await step('the instructor drops pallet P2 and puts spill S1 down: each then says so, and cannot be started again', async () => {
    for (const [id, done, status] of [['P2', 'Pallet P2 falls from its rack now.', 'P2: (falling from its rack|fallen, on the floor)'],
                                       ['S1', 'Spill S1 is on the floor now.', 'S1: a spill, on the floor']]) {
      const button = `#hazard-list button[data-hazard="${id}"]`;
      check(await page.getAttribute(button, 'aria-disabled') === 'false', `${id} waits for the instructor`);
      await page.click(button);
      await page.waitForSelector(`#message:has-text("${done}")`);
      await page.waitForFunction(([sel, re]) => new RegExp(re).test(document.querySelector(sel).textContent),
                                 [`li[data-hazard="${id}"]`, status]);
      check(await page.getAttribute(button, 'aria-disabled') === 'true', `${id} cannot be started again`);
    }
    await page.waitForSelector('#plan-svg rect.spill[data-spill="S1"][data-on-floor="true"]');
    check(/Spill S1: on the floor, the tyres grip 20 % of their own/.test(await page.textContent('#plan-svg rect.spill[data-spill="S1"] title')),
          `the plan names it: ${await page.textContent('#plan-svg rect.spill[data-spill="S1"] title')}`);
    await page.waitForSelector('li[data-hazard="P2"][data-activity="down"]', { timeout: 10000 });
    check(/P2: fallen, on the floor/.test(await page.textContent('li[data-hazard="P2"]')), 'the pallet lies on the floor, in words');
    const live = (await api('GET', `/sessions/${session.id}/live`, ines)).state;
    check(JSON.stringify([live.falling_pallets.started, live.falling_pallets.landed, live.spills_on_floor]) === '[[0],[0],[0]]',
          `the live state says so: ${JSON.stringify(live.falling_pallets)}, ${JSON.stringify(live.spills_on_floor)}`);
  });

  await step('the plan follows him north along the walkway', async () => {
    const first = await figure('W1');
    await page.waitForFunction((y0) => {
      const g = document.querySelector('#plan-svg g.person[data-pedestrian="W1"]');
      return g && Number(g.dataset.y) > y0 + 0.5;
    }, first.y, { timeout: 10000 });
    const later = await figure('W1');
    check(Math.abs(later.x - 26.75) < 0.01, `on the walkway: ${JSON.stringify(later)}`);
    await shot('session-live-pedestrian-walking');
    const audit = await api('GET', `/pupils/${pupil.id}/audit`, admin);
    check(audit.some((r) => r.action === 'hazard_started'), `audited: ${audit.map((r) => r.action)}`);
  });

  await step('the debrief replay draws him waiting before the hazard and walking after it', async () => {
    await page.waitForSelector('#replay[data-ready=true]', { timeout: 120000 });
    forget(/(HTTP 409 for GET .*\/live$|HTTP 503 for GET .*\/replay$|status of (409|503) )/);
    const replay = await api('GET', `/sessions/${session.id}/replay`, ines);
    check(JSON.stringify(replay.pedestrian_ids) === '["W1","W2"]', `the replay names him (and the worker past the door): ${replay.pedestrian_ids}`);
    check(JSON.stringify(replay.truck_ids) === '["T1","T2"]', `and the trucks: ${replay.truck_ids}`);
    const started = replay.samples.findIndex((s) => s.pedestrians[0][3] === 'walking');
    check(started > 2, `he starts walking part way: sample ${started}`);
    for (const sample of [replay.samples[1], replay.samples[started + 5]]) {
      await page.$eval('#replay-time', (e, t) => { e.value = String(t); e.dispatchEvent(new Event('input')); }, sample.t);
      await page.waitForFunction((t) => Math.abs(Number(document.getElementById('replay-truck').dataset.t) - t) < 0.011, sample.t);
      const drawn = await figure('W1');
      const [x, y, , activity] = sample.pedestrians[0];
      check(drawn.activity === activity && Math.hypot(drawn.x - x, drawn.y - y) < 0.01,
            `at t = ${sample.t} s the replay draws him ${JSON.stringify(drawn)}, the re-run has ${JSON.stringify(sample.pedestrians[0])}`);
    }
    check((await figure('W1')).activity === 'walking', 'walking after the hazard');
    await shot('session-replay-pedestrian');
  });
  console.log('pedestrians: all steps passed');
  await browser.close();
  await procs.stopAll();
  process.exit(problems.length ? 1 : 0);
} catch (e) {
  await failed(e, { ...side, out, procs, logs: procs.tail('server') + '\n' + procs.tail('cab') });
}
