// A session's page: GET /api/sessions/{id} (facts, events, score), its path and its scenario's
// plan; the timeline with worry levels and the marking sheet; stills at events when the renderer
// exists. While the session runs, the page refreshes every two seconds.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, dateTime, num, param, isStaff, worryName, pct } = FL;
  const me = requireLogin();
  const id = param('id');
  const message = document.getElementById('message');
  const TERMINAL = ['ended', 'failed', 'aborted'];
  let plan = null, planFor = null, drawn = null, current = null, last = null;

  function badge(cls, text) { return el('span', { class: `badge ${cls}` }, text); }
  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }

  function loadText(load) {
    if (!load) return 'none';
    const parts = [`${num(load.mass_kg, 0)} kg`];
    if (load.cog_height_m !== undefined) parts.push(`centre of gravity ${num(load.cog_height_m, 2)} m up`);
    if (load.lateral_m) parts.push(`${num(load.lateral_m, 2)} m to the ${load.lateral_m > 0 ? 'left' : 'right'}`);
    return parts.join(', ');
  }

  function facts(s, pupil) {
    document.getElementById('heading').textContent = `Session ${s.id}`;
    document.title = `Session ${s.id} · Forklift school`;
    const dl = clear(document.getElementById('facts'));
    fact(dl, 'Pupil', pupil ? el('a', { href: `pupil.html?id=${encodeURIComponent(s.pupil_id)}` }, pupil.name) : `#${s.pupil_id}`);
    fact(dl, 'Scenario', s.scenario, plan && plan.task && plan.task.summary ? el('div', { class: 'small muted' }, plan.task.summary) : '');
    fact(dl, 'Truck', s.truck ? `${s.truck.title}${s.truck.osha_class ? ` (${s.truck.osha_class})` : ''}` : 'the scenario\'s default');
    fact(dl, 'Load', loadText(s.load));
    fact(dl, 'Cab', s.cab_id);
    fact(dl, 'Mode', s.mode);
    fact(dl, 'State', badge(s.state, s.state), s.reason ? ` ${s.reason}` : '');
    fact(dl, 'Started', dateTime(s.created_at));
    if (s.ended_at) fact(dl, 'Ended', dateTime(s.ended_at));
    // Only a session that ran its course has a mark; the others say how they ended instead.
    const unmarked = { timed_out: 'no mark: the time ran out', aborted: 'no mark: the session was aborted',
                       stopped: 'no mark: the session was stopped before its end', failed: 'no mark: the session failed',
                       completed: 'not marked yet', open: 'not marked yet' };
    fact(dl, 'Mark', s.mark === null ? el('span', { class: 'muted', id: 'no-mark', 'data-outcome': s.outcome }, unmarked[s.outcome] || 'no mark')
                                     : [el('strong', { id: 'mark' }, num(s.mark)), ' ', s.passed === null ? '' : s.passed ? badge('passed', 'passed') : badge('not-passed', 'not passed')]);
    if (s.reasons && s.reasons.length && s.passed !== true)
      fact(dl, s.mode === 'exam' ? 'Why it did not pass' : 'Why', el('ul', { class: 'small reasons' }, s.reasons.map((r) => el('li', { 'data-code': r.code }, r.text))));
  }

  function actions(s) {
    const box = clear(document.getElementById('actions'));
    if (isStaff(me) && !TERMINAL.includes(s.state)) {
      box.append(el('button', { type: 'button', class: 'danger', onclick: async () => {
        try { await api('POST', `/sessions/${encodeURIComponent(s.id)}/abort`); refresh(); } catch (e) { say(message, describeError(e)); }
      } }, 'Abort the session'));
    }
  }

  // The marking sheet: the score's counts when the session was marked; else the faults noted.
  function sheet(s) {
    const worst = {}, counted = {};
    for (const e of s.events) {
      if (e.worry_level <= 0) continue;
      worst[e.kind] = Math.max(worst[e.kind] || 0, e.worry_level);
      counted[e.kind] = (counted[e.kind] || 0) + 1;
    }
    const counts = s.score ? s.score.counts : s.counts || counted;
    const rows = Object.entries(counts).sort((a, b) => b[1] - a[1]).map(([k, n]) => el('tr', {},
      el('th', { scope: 'row' }, k), el('td', {}, worst[k] ? badge(worryName(worst[k]), worryName(worst[k])) : ''), el('td', { class: 'num' }, n)));
    if (rows.length === 0) rows.push(el('tr', {}, el('td', { colspan: 3, class: 'muted' }, 'No faults.')));
    if (s.score) rows.push(el('tr', {}, el('th', { scope: 'row' }, 'Mark'), el('td', {}, s.score.passed ? badge('passed', 'passed') : badge('not-passed', 'not passed')),
                                 el('td', { class: 'num' }, num(s.score.mark))));
    clear(document.querySelector('#sheet tbody')).append(...rows);
    document.getElementById('sheet-heading').textContent = s.score ? 'Marking sheet' : 'Marking sheet (faults counted; no mark)';
  }

  async function showStill(s, e, box, button) {
    button.disabled = true;
    button.textContent = 'Rendering…';
    try {
      const blob = await api('GET', `/sessions/${encodeURIComponent(s.id)}/events/${e.seq}/still.png`);
      box.append(el('img', { src: URL.createObjectURL(blob), alt: `The scene from behind the truck at event ${e.seq} (${e.kind}), t = ${num(e.sim_time_s)} s` }));
      button.remove();
    } catch (err) {
      button.textContent = 'No still';
      box.append(el('p', { class: 'error small' }, describeError(err)));
    }
  }

  // An event's details: the evaluator writes JSON (a description for the pupil, what it measured,
  // where its rule comes from); anything else is shown as it is.
  function details(text) {
    if (!text) return '';
    let d = null;
    try { d = JSON.parse(text); } catch (e) { /* plain text, or JSON cut short by the message's 255 characters */ }
    if (!d || typeof d !== 'object' || Array.isArray(d)) {
      const cut = /^\{"description":"((?:[^"\\]|\\.)*)"/.exec(text);
      if (!cut) return el('div', { class: 'small' }, text);
      let description = cut[1];
      try { description = JSON.parse(`"${cut[1]}"`); } catch (e) { /* as it came */ }
      return el('div', { class: 'small' }, el('div', {}, description), el('div', { class: 'muted' }, '(the rest of the details was cut short in transit)'));
    }
    const round = (v) => (typeof v === 'number' ? String(Math.round(v * 1000) / 1000) : Array.isArray(v) ? v.join(', ') : String(v));
    const measured = d.measured && typeof d.measured === 'object'
      ? Object.entries(d.measured).map(([k, v]) => `${k.replace(/_/g, ' ')} ${round(v)}`).join('; ') : '';
    const rest = Object.entries(d).filter(([k]) => !['description', 'measured', 'source'].includes(k))
      .map(([k, v]) => `${k.replace(/_/g, ' ')}: ${typeof v === 'object' && !Array.isArray(v) ? JSON.stringify(v) : round(v)}`).join('; ');
    return el('div', { class: 'small' },
      d.description ? el('div', {}, d.description) : '',
      measured ? el('div', { class: 'muted' }, `measured: ${measured}`) : '',
      rest ? el('div', { class: 'muted' }, rest) : '',
      d.source ? el('div', { class: 'muted' }, `rule: ${d.source}`) : '');
  }

  function select(seq) {
    current = seq;
    if (drawn) drawn.select(seq);
    for (const li of document.querySelectorAll('#timeline li')) li.classList.toggle('current', Number(li.dataset.seq) === seq);
  }

  function timeline(s) {
    const ol = clear(document.getElementById('timeline'));
    if (s.events.length === 0) ol.append(el('li', { class: 'muted' }, 'No events.'));
    for (const e of s.events) {
      const still = el('div', { class: 'still' });
      const li = el('li', { class: `w${e.worry_level}`, 'data-seq': e.seq },
        el('span', { class: 'when' }, `${e.seq}. t = ${num(e.sim_time_s)} s`),
        el('strong', {}, e.kind), ' ', badge(worryName(e.worry_level), worryName(e.worry_level)),
        details(e.details),
        el('div', { class: 'small muted' }, `at x ${num(e.x_m)} m, y ${num(e.y_m)} m `,
           el('button', { type: 'button', class: 'link', onclick: () => select(e.seq) }, 'show on the plan')),
        still);
      if (s.stills_available) {
        const b = el('button', { type: 'button', class: 'secondary' }, 'Show the still');
        b.addEventListener('click', () => showStill(s, e, still, b));
        still.append(b);
      }
      ol.append(li);
    }
    if (current !== null) select(current);
  }

  async function refresh() {
    let s, path, pupil = null;
    try {
      [s, path] = await Promise.all([api('GET', `/sessions/${encodeURIComponent(id)}`), api('GET', `/sessions/${encodeURIComponent(id)}/path`)]);
    } catch (e) {
      say(message, describeError(e));
      return null;
    }
    try { pupil = await api('GET', `/pupils/${encodeURIComponent(s.pupil_id)}`); } catch (e) { /* shown as its id */ }
    if (planFor !== s.scenario) {
      planFor = s.scenario;
      try { plan = await api('GET', `/scenarios/${encodeURIComponent(s.scenario)}/plan`); } catch (e) { plan = null; console.warn(e); }
    }
    const key = JSON.stringify([s.state, s.events.length, path.points.length, s.mark]);
    if (key !== last) {  // redraw only what changed
      last = key;
      facts(s, pupil);
      actions(s);
      sheet(s);
      drawn = FLPlan.draw(document.getElementById('plan'), { plan, path: path.points, events: s.events,
        title: `Plan of ${s.scenario} with the path of session ${s.id}`, onEvent: select });
      timeline(s);
    }
    return s;
  }

  // Live follow for staff (the remote examiner): the truck's state and the cab's view, twice a
  // second while the session runs. The frame comes as a blob (the token never goes in a URL).
  let liveUrl = null, liveBusy = false;
  async function live(s) {
    const box = document.getElementById('live');
    const running = isStaff(me) && (s.state === 'waiting' || s.state === 'running');
    box.hidden = !running;
    if (!running || liveBusy) return;
    liveBusy = true;
    try {
      const v = await api('GET', `/sessions/${encodeURIComponent(s.id)}/live`);
      const dl = clear(document.getElementById('live-state'));
      if (v.state) {
        fact(dl, 'Time', `${num(v.state.sim_time_s)} s`);
        fact(dl, 'Speed', `${num(v.state.speed_m_s, 2)} m/s`);
        fact(dl, 'Forks', `${num(v.state.lift_m, 2)} m`);
        fact(dl, 'Load', v.state.load_attached ? `${num(v.state.load_mass_kg, 0)} kg` : 'none');
        fact(dl, 'Stability', pct(v.state.stability_margin));
        if (v.state.deadman) fact(dl, 'Dead man', badge('failed', 'cab silent: truck stopped'));
      } else {
        fact(dl, 'Truck', 'waiting for the cab');
      }
      if (!v.frame_available && !liveUrl) fact(dl, 'View', el('span', { class: 'muted' }, 'no frames from this cab\'s worker'));
      if (v.frame_available) {
        const blob = await api('GET', `/sessions/${encodeURIComponent(s.id)}/live/frame.jpg`);
        const old = liveUrl;
        liveUrl = URL.createObjectURL(blob);
        const img = document.getElementById('live-frame');
        img.src = liveUrl;
        img.hidden = false;
        if (old) URL.revokeObjectURL(old);
      }
    } catch (e) {
      console.warn(e);
    } finally {
      liveBusy = false;
    }
  }

  if (!id) { say(message, 'Which session? Open this page from a pupil or the fleet.'); return; }
  let shown = null;  // the session as last fetched
  FL.poll(async () => { if (shown) await live(shown); }, 500, () => shown && TERMINAL.includes(shown.state));
  // Until the session is over, and then a little longer for its mark (the score follows the end).
  let done = false, endedAt = null;
  FL.poll(async () => {
    const s = await refresh();
    if (s) shown = s;
    if (s && TERMINAL.includes(s.state)) live(s);  // hides the panel
    if (!s || !TERMINAL.includes(s.state)) return;
    endedAt = endedAt || Date.now();
    done = s.mark !== null || s.outcome !== 'completed' || Date.now() - endedAt > 30000;
  }, 2000, () => done);
})();
