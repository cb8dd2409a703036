// A session's page: GET /api/sessions/{id} (facts, events, score), its path and its scenario's
// plan; the timeline with worry levels and the marking sheet; stills at events when the renderer
// exists. While the session runs, the page refreshes every two seconds. Once it has ended, the
// debrief: a replay re-simulated from its control log (GET .../replay), scrubbed in time over the
// plan with the events on the same timeline, and the instructor's notes and sign-off.
'use strict';
(async () => {
  const { api, el, clear, requireLogin, say, describeError, dateTime, num, param, isStaff, worryName, worryClass, pct, stateText, reasonText, t } = FL;
  const me = requireLogin();
  const id = param('id');
  const message = document.getElementById('message');
  const TERMINAL = ['ended', 'failed', 'aborted'];
  let plan = null, planFor = null, drawn = null, current = null, last = null;

  function badge(cls, text) { return el('span', { class: `badge ${cls}` }, text); }
  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }
  function passBadge(passed) { return passed ? badge('passed', t('passed')) : badge('not-passed', t('not_passed')); }
  // The task in a line, in the scenario's own words (English: not translated yet).
  function taskSummary() {
    const summary = plan && plan.task && plan.task.summary;
    return summary ? FL.english(summary) : null;
  }

  function loadText(load) {
    if (!load) return t('session.load_none');
    const parts = [t('session.load_kg', { mass: num(load.mass_kg, 0) })];
    if (load.cog_height_m !== undefined) parts.push(t('session.load_cog', { height: num(load.cog_height_m, 2) }));
    if (load.lateral_m) parts.push(t(load.lateral_m > 0 ? 'session.load_left' : 'session.load_right', { offset: num(Math.abs(load.lateral_m), 2) }));
    return parts.join(', ');
  }

  function facts(s, pupil) {
    document.getElementById('heading').textContent = t('session.heading_id', { id: s.id });
    document.title = t('title', { page: t('session.heading_id', { id: s.id }) });
    const dl = clear(document.getElementById('facts'));
    fact(dl, t('session.pupil'), pupil ? el('a', { href: `pupil.html?id=${encodeURIComponent(s.pupil_id)}` }, pupil.name) : `#${s.pupil_id}`);
    fact(dl, t('session.scenario'), s.scenario, taskSummary() ? el('div', { class: 'small muted' }, taskSummary()) : '');
    const truck = s.truck ? FL.truckWords(s.truck) : null;
    fact(dl, t('session.truck'), truck ? `${truck.title}${truck.osha_class ? ` (${truck.osha_class})` : ''}` : t('session.default_truck'));
    fact(dl, t('session.load'), loadText(s.load));
    fact(dl, t('session.cab'), s.cab_id);
    fact(dl, t('session.mode'), t(`mode.${s.mode}`));
    fact(dl, t('session.state'), badge(s.state, stateText(s.state)), s.reason ? ` (${reasonText(s.reason)})` : '');
    fact(dl, t('session.started'), dateTime(s.created_at));
    if (s.ended_at) fact(dl, t('session.ended'), dateTime(s.ended_at));
    // Only a session that ran its course has a mark; the others say how they ended instead.
    const unmarked = ['timed_out', 'aborted', 'stopped', 'failed', 'completed', 'open'].includes(s.outcome) ? s.outcome : 'other';
    fact(dl, t('session.mark'), s.mark === null ? el('span', { class: 'muted', id: 'no-mark', 'data-outcome': s.outcome }, t(`session.unmarked.${unmarked}`))
                                     : [el('strong', { id: 'mark' }, num(s.mark)), ' ', s.passed === null ? '' : passBadge(s.passed)]);
    if (s.reasons && s.reasons.length && s.passed !== true)
      fact(dl, t(s.mode === 'exam' ? 'session.why_not_passed' : 'session.why'), el('ul', { class: 'small reasons' }, s.reasons.map((r) => el('li', { 'data-code': r.code }, FL.reasonWords(r, s.reason)))));
  }

  function actions(s) {
    const box = clear(document.getElementById('actions'));
    if (isStaff(me) && !TERMINAL.includes(s.state)) {
      box.append(el('button', { type: 'button', class: 'danger', onclick: async () => {
        try { await api('POST', `/sessions/${encodeURIComponent(s.id)}/abort`); refresh(); } catch (e) { say(message, describeError(e)); }
      } }, t('session.abort')));
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
    const titles = {};
    for (const e of s.events) if (e.words) titles[e.kind] = e.words.title;
    const rows = Object.entries(counts).sort((a, b) => b[1] - a[1]).map(([k, n]) => el('tr', {},
      el('th', { scope: 'row', 'data-kind': k }, titles[k] || k.replace(/_/g, ' ')), el('td', {}, worst[k] ? badge(worryClass(worst[k]), worryName(worst[k])) : ''), el('td', { class: 'num' }, n)));
    if (rows.length === 0) rows.push(el('tr', {}, el('td', { colspan: 3, class: 'muted' }, t('session.no_faults'))));
    if (s.score) rows.push(el('tr', {}, el('th', { scope: 'row' }, t('session.mark')), el('td', {}, passBadge(s.score.passed)),
                                 el('td', { class: 'num' }, num(s.score.mark))));
    clear(document.querySelector('#sheet tbody')).append(...rows);
    document.getElementById('sheet-heading').textContent = t(s.score ? 'session.sheet' : 'session.sheet_no_mark');
  }

  async function showStill(s, e, box, button) {
    button.disabled = true;
    button.textContent = t('session.rendering');
    try {
      const blob = await api('GET', `/sessions/${encodeURIComponent(s.id)}/events/${e.seq}/still.png`);
      box.append(el('img', { src: URL.createObjectURL(blob), alt: t('session.still_alt', { seq: e.seq, title: e.words ? e.words.title : e.kind, time: num(e.sim_time_s) }) }));
      button.remove();
    } catch (err) {
      button.textContent = t('session.no_still');
      box.append(el('p', { class: 'error small' }, describeError(err)));
    }
  }

  // An event's details: what the pupil did in the rule's words, what was measured against its
  // limit in units (the server's words for the evaluator's numbers), and where the rule comes from.
  // The rule's description as the evaluator wrote it (the rules file's English), or the catalogue's
  // in the page's language.
  function description(e, english) {
    return document.documentElement.lang !== 'en' && FL.has(`words:rules.${e.kind}.description`) ? t(`words:rules.${e.kind}.description`) : FL.english(english);
  }

  function details(e) {
    let d = null;
    try { d = JSON.parse(e.details); } catch (err) { /* plain text, or cut short in transit */ }
    if (!d || typeof d !== 'object' || Array.isArray(d)) return e.details ? el('div', { class: 'small' }, e.details) : '';
    const words = e.words || {};
    const what = Object.entries(d).filter(([k, v]) => typeof v === 'string' && !['description', 'source'].includes(k))
      .map(([k, v]) => `${k.replace(/_/g, ' ')}: ${v.replace(/_/g, ' ')}`).join('; ');
    return el('div', { class: 'small' },
      d.description ? el('div', {}, description(e, d.description)) : '',
      words.summary ? el('div', { class: 'measured' }, words.summary) : '',
      what ? el('div', { class: 'muted' }, FL.english(what)) : '',
      d.source ? el('div', { class: 'muted' }, FL.tAround('session.rule', 'source', FL.english(d.source))) : '');
  }

  function select(seq) {
    current = seq;
    const e = shownEvents.find((x) => x.seq === seq);
    if (e && replay) setTime(e.sim_time_s);
    if (drawn) drawn.select(seq);
    for (const li of document.querySelectorAll('#timeline li')) li.classList.toggle('current', Number(li.dataset.seq) === seq);
  }

  function timeline(s) {
    const ol = clear(document.getElementById('timeline'));
    if (s.events.length === 0) ol.append(el('li', { class: 'muted' }, t('session.no_events')));
    for (const e of s.events) {
      const still = el('div', { class: 'still' });
      const li = el('li', { class: `w${e.worry_level}`, 'data-seq': e.seq },
        el('span', { class: 'when' }, `${e.seq}. t = ${num(e.sim_time_s)} s`),
        el('strong', { 'data-kind': e.kind }, e.words ? e.words.title : e.kind), ' ', badge(worryClass(e.worry_level), worryName(e.worry_level)),
        details(e),
        el('div', { class: 'small muted' }, t('session.at', { x: num(e.x_m), y: num(e.y_m) }),
           el('button', { type: 'button', class: 'link show-event', onclick: () => select(e.seq) },
              t(replay ? 'session.show_replay' : 'session.show_plan'))),
        still);
      if (s.stills_available) {
        const b = el('button', { type: 'button', class: 'secondary' }, t('session.show_still'));
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
      [s, path] = await Promise.all([api('GET', `/sessions/${encodeURIComponent(id)}?lang=${encodeURIComponent(lang)}`), api('GET', `/sessions/${encodeURIComponent(id)}/path`)]);
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
        title: t('session.plan_title', { scenario: s.scenario, id: s.id }), onEvent: select });
      shownEvents = s.events;
      timeline(s);
      if (replay) drawReplay();
      else drawLive();
    }
    if (TERMINAL.includes(s.state)) {
      loadReplay(s);
      debrief(s);
    }
    return s;
  }

  // ---------------------------------------------------------------- the replay
  let replay = null, replayAsked = false, replayT = 0, playing = false, shownEvents = [];
  const rs = { section: document.getElementById('replay'), status: document.getElementById('replay-status'),
               play: document.getElementById('replay-play'), speed: document.getElementById('replay-speed'),
               time: document.getElementById('replay-time'), clock: document.getElementById('replay-clock'),
               marks: document.getElementById('replay-marks'), state: document.getElementById('replay-state') };

  async function loadReplay(s) {
    if (replayAsked) return;
    replayAsked = true;
    rs.section.hidden = false;
    say(rs.status, t('session.preparing'), 'status');
    try {
      let r = null;
      for (let i = 0; !r; i++) {
        try {
          r = await api('GET', `/sessions/${encodeURIComponent(s.id)}/replay`);
        } catch (e) {  // just ended: its log is on its way to the store
          if (e.code !== 'not_ready' || i >= 60) throw e;
          await new Promise((ok) => setTimeout(ok, 1000));
        }
      }
      if (!r.samples || r.samples.length === 0) throw new Error(t('session.no_states'));
      replay = r;
    } catch (e) {
      say(rs.status, FL.tAround('session.no_replay', 'why', describeError(e)));
      return;
    }
    const end = replay.samples[replay.samples.length - 1].t;
    clear(rs.status).append(t('session.replay_status', { count: replay.samples.length, time: num(end) }),
      replay.failure ? t('session.replay_failed', { why: replay.failure }) : '', '.');
    rs.time.max = String(end);
    rs.time.disabled = rs.play.disabled = false;
    clear(rs.marks).append(...shownEvents.map((e) => {
      const b = el('button', { type: 'button', class: `w${e.worry_level}`, 'data-seq': e.seq, tabindex: -1,
        title: t('session.event_mark', { seq: e.seq, title: e.words ? e.words.title : e.kind, time: num(e.sim_time_s) }), onclick: () => select(e.seq) });
      b.style.left = `${Math.min(100, 100 * e.sim_time_s / end).toFixed(2)}%`;  // CSSOM: the pages' CSP allows no style attribute
      return b;
    }));
    for (const b of document.querySelectorAll('#timeline .show-event')) b.textContent = t('session.show_replay');
    rs.section.dataset.ready = 'true';
    setTime(current !== null ? (shownEvents.find((e) => e.seq === current) || { sim_time_s: 0 }).sim_time_s : 0);
  }

  // The state at time t, between the two samples around it (angles the short way round).
  function stateAt(t) {
    const ss = replay.samples;
    let lo = 0, hi = ss.length - 1;
    if (t <= ss[0].t) return ss[0];
    if (t >= ss[hi].t) return ss[hi];
    while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (ss[mid].t <= t) lo = mid; else hi = mid; }
    const a = ss[lo], b = ss[hi], f = (t - a.t) / (b.t - a.t);
    const mix = (p, q) => p + (q - p) * f;
    const angle = (p, q) => p + ((((q - p) % 360) + 540) % 360 - 180) * f;
    const pair = (p, q) => [mix(p[0], q[0]), mix(p[1], q[1])];
    return { ...a, t, x_m: mix(a.x_m, b.x_m), y_m: mix(a.y_m, b.y_m), yaw_deg: angle(a.yaw_deg, b.yaw_deg),
             body_m: pair(a.body_m, b.body_m), body_yaw_deg: angle(a.body_yaw_deg, b.body_yaw_deg),
             speed_m_s: mix(a.speed_m_s, b.speed_m_s), lift_m: mix(a.lift_m, b.lift_m), tilt_deg: mix(a.tilt_deg, b.tilt_deg),
             fork_height_m: mix(a.fork_height_m, b.fork_height_m), fork_heel_m: pair(a.fork_heel_m, b.fork_heel_m),
             fork_tip_m: pair(a.fork_tip_m, b.fork_tip_m),
             pallets: a.pallets.map((p, i) => [mix(p[0], b.pallets[i][0]), mix(p[1], b.pallets[i][1]), mix(p[2], b.pallets[i][2]),
                                                angle(p[3], b.pallets[i][3])]),
             // a replay made before people were sampled has none
             pedestrians: (a.pedestrians || []).map((p, i) => {
               const q = (b.pedestrians || [])[i] || p;
               return [mix(p[0], q[0]), mix(p[1], q[1]), angle(p[2], q[2]), p[3]];
             }),
             trucks: (a.trucks || []).map((p, i) => {
               const q = (b.trucks || [])[i] || p;
               return [mix(p[0], q[0]), mix(p[1], q[1]), angle(p[2], q[2]), p[3]];
             }) };
  }

  function setTime(t) {
    replayT = Math.max(0, Math.min(t, Number(rs.time.max)));
    rs.time.value = String(replayT);
    drawReplay();
  }

  // The other trucks of a replay's state, as the plan draws them.
  const replayTrucks = (st) => (st.trucks || []).map(([x_m, y_m, heading_deg, activity], i) =>
    ({ id: replay.truck_ids ? replay.truck_ids[i] : String(i + 1), x_m, y_m, heading_deg, activity }));
  // The people of a replay's state, as the plan draws them.
  const replayPeople = (st) => (st.pedestrians || []).map(([x_m, y_m, heading_deg, activity], i) =>
    ({ id: replay.pedestrian_ids ? replay.pedestrian_ids[i] : String(i + 1), x_m, y_m, heading_deg, activity }));

  function drawReplay() {
    if (!replay || !drawn) return;
    const st = stateAt(replayT);
    const { overlay, X, Y, u } = drawn;
    const pts = (ps) => ps.map(([x, y]) => `${X(x).toFixed(3)},${Y(y).toFixed(3)}`).join(' ');
    // the pallets where they stand now: each drawn at its plan pose, moved by the difference
    replay.pallet_ids.forEach((pid, i) => {
      const shape = drawn.shapeOf(pid), o = drawn.objectsById.get(pid);
      if (!shape || !o) return;
      const [x, y, , yaw] = st.pallets[i];
      shape.setAttribute('transform', `translate(${X(x)} ${Y(y)}) rotate(${-(yaw - (o.yaw_deg || 0))}) translate(${-X(o.x_m)} ${-Y(o.y_m)})`);
    });
    // the truck: the chassis's footprint at its pose, and the forks from heel to tip
    const fp = replay.truck.chassis_footprint_m || [-2.2, -0.5, 0.3, 0.5];
    const a = st.body_yaw_deg * Math.PI / 180, c = Math.cos(a), sn = Math.sin(a), [bx, by] = st.body_m;
    const body = [[fp[0], fp[1]], [fp[2], fp[1]], [fp[2], fp[3]], [fp[0], fp[3]]].map(([x, y]) => [bx + c * x - sn * y, by + sn * x + c * y]);
    const half = replay.truck.fork_centres_y_m / 2, nx = -sn * half, ny = c * half;
    const fork = (k) => FL.svg('line', { x1: X(st.fork_heel_m[0] + k * nx), y1: Y(st.fork_heel_m[1] + k * ny), x2: X(st.fork_tip_m[0] + k * nx),
                                        y2: Y(st.fork_tip_m[1] + k * ny), stroke: st.load ? '#6e3b0a' : '#222', 'stroke-width': replay.truck.fork_width_m });
    const g = FL.svg('g', { id: 'replay-truck', 'data-t': st.t.toFixed(2), 'data-x': st.x_m.toFixed(3), 'data-y': st.y_m.toFixed(3),
                            'data-yaw': st.yaw_deg.toFixed(2), 'data-fork-height': st.fork_height_m.toFixed(3), 'data-load': st.load || '' },
      FL.svg('polygon', { points: pts(body), fill: '#f2c230', 'fill-opacity': 0.9, stroke: '#222', 'stroke-width': u * 0.25 }),
      fork(1), fork(-1),
      FL.svg('circle', { cx: X(st.x_m), cy: Y(st.y_m), r: u * 0.5, fill: '#222' }),
      FL.svg('title', {}, t('session.truck_at', { time: num(st.t) })));
    const people = replayPeople(st);
    clear(overlay).append(g, drawn.people(people), drawn.trucks(replayTrucks(st)));
    drawn.keepInView(st.x_m, st.y_m);
    rs.clock.textContent = `t = ${num(st.t)} s`;
    const dl = clear(rs.state);
    fact(dl, t('session.speed_label'), t('session.speed_value', { speed: num(Math.abs(st.speed_m_s), 2), kmh: num(Math.abs(st.speed_m_s) * 3.6) }) +
      (st.speed_m_s < -0.02 ? t('session.reversing') : ''));
    fact(dl, t('session.forks'), st.fork_height_m < 1 ? t('session.cm_up', { height: num(st.fork_height_m * 100, 0) }) : t('session.m_up', { height: num(st.fork_height_m, 2) }));
    fact(dl, t('session.tilt'), `${num(Math.abs(st.tilt_deg))}° ${st.tilt_deg > 0.05 ? t('session.back') : st.tilt_deg < -0.05 ? t('session.forward') : ''}`);
    fact(dl, t('session.load'), st.load ? t('session.pallet_on', { id: st.load }) : t('session.none_on'));
    if (people.length) fact(dl, t('session.pedestrians'), peopleWords(people));
  }

  rs.time.addEventListener('input', () => { playing = false; rs.play.textContent = t('session.play'); setTime(Number(rs.time.value)); });
  rs.play.addEventListener('click', () => {
    playing = !playing;
    rs.play.textContent = t(playing ? 'session.pause_replay' : 'session.play');
    if (!playing) return;
    if (replayT >= Number(rs.time.max)) setTime(0);
    let before = performance.now();
    const frame = (now) => {
      if (!playing) return;
      setTime(replayT + (now - before) / 1000 * Number(rs.speed.value));
      before = now;
      if (replayT >= Number(rs.time.max)) { playing = false; rs.play.textContent = t('session.play'); return; }
      requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
  });

  // ---------------------------------------------------------------- notes and sign-off
  const ds = { notes: document.getElementById('notes'), signed: document.getElementById('signed-off'),
               noteForm: document.getElementById('note-form'), noteText: document.getElementById('note-text'),
               signForm: document.getElementById('sign-off-form'), comment: document.getElementById('sign-off-comment') };
  let debriefFor = null;
  function showDebrief(d) {
    clear(ds.notes).append(...(d.notes.length ? d.notes.map((n) => el('li', { 'data-note': n.id },
      el('div', { class: 'small muted' }, `${n.author.name}, ${dateTime(n.at)}`), n.text)) : [el('li', { class: 'muted' }, t('session.no_notes'))]));
    ds.signed.hidden = !d.sign_off;
    if (d.sign_off) clear(ds.signed).append(badge('passed', t('session.signed_off')), t('session.signed_by', { name: d.sign_off.by.name, at: dateTime(d.sign_off.at) }),
                                            d.sign_off.comment ? `: ${d.sign_off.comment}` : '');
    ds.noteForm.hidden = !isStaff(me) || !!d.sign_off;
    ds.signForm.hidden = !isStaff(me) || !!d.sign_off || !d.finished;
  }
  async function debrief(s) {
    if (debriefFor === s.id) return;
    debriefFor = s.id;
    try { showDebrief(await api('GET', `/sessions/${encodeURIComponent(s.id)}/debrief`)); } catch (e) { say(message, describeError(e)); }
  }
  ds.noteForm.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    try {
      showDebrief(await api('POST', `/sessions/${encodeURIComponent(id)}/notes`, { text: ds.noteText.value }));
      ds.noteText.value = '';
      say(message, t('session.note_added'), 'status');
    } catch (e) { say(message, describeError(e)); }
  });
  ds.signForm.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    try {
      showDebrief(await api('POST', `/sessions/${encodeURIComponent(id)}/sign-off`, { comment: ds.comment.value }));
      say(message, t('session.signed_done'), 'status');
    } catch (e) { say(message, describeError(e)); }
  });

  // Live follow for staff (the remote examiner): the truck's state and the cab's view, twice a
  // second while the session runs. The frame comes as a blob (the token never goes in a URL).
  let liveUrl = null, liveBusy = false;
  // 95.4 s as "1 min 35 s"; under a minute as "35 s".
  const minutesSeconds = (s) => {
    const whole = Math.max(0, Math.floor(s));
    return whole >= 60 ? t('session.min_s', { min: Math.floor(whole / 60), s: whole % 60 }) : t('session.s', { s: whole });
  };
  // The people who move, in words: "W1 walking, W2 waiting for his cue".
  const peopleWords = (list) => list.map((p) => `${p.id} ${drawn ? drawn.activityWords(p.activity) : p.activity}`).join(', ');

  // While the session runs, the truck and the people where they are now, over the plan (the
  // replay's overlay once the session has ended).
  let liveState = null;
  function drawLive() {
    if (!drawn || replay) return;
    const { overlay, X, Y, u } = drawn;
    drawn.showSpills(liveState ? liveState.spills_on_floor : []);
    if (!liveState) { clear(overlay); return; }
    const truck = FL.svg('circle', { id: 'live-truck', cx: X(liveState.x_m), cy: Y(liveState.y_m), r: u * 1.2, fill: '#f2c230', stroke: '#222',
                                     'stroke-width': u * 0.25, 'data-t': liveState.sim_time_s.toFixed(2) },
                         FL.svg('title', {}, t('session.truck_now', { time: num(liveState.sim_time_s) })));
    clear(overlay).append(truck, drawn.people(liveState.pedestrians || []), drawn.trucks(liveState.trucks || []));
  }

  // "Hazard now": each of the scenario's hazards (the people who move, the other trucks, the
  // pallets that fall, the spills that wait for a trigger), with what each is doing, and a button that starts one waiting for its cue
  // (the API refuses the others, and any in an exam). The items are kept from one poll to the
  // next, so that the keyboard's focus stays where it is.
  const hazardItems = new Map();
  function hazardControls(s, state) {
    const words = (a, truck) => drawn ? (truck ? drawn.truckWords(a) : drawn.activityWords(a)) : a;
    // The pallets that fall and the spills by their places in the plan's lists, as the worker says.
    const fell = new Set(state && state.falling_pallets ? state.falling_pallets.started : []);
    const landed = new Set(state && state.falling_pallets ? state.falling_pallets.landed : []);
    const spilt = new Set(state && state.spills_on_floor ? state.spills_on_floor : []);
    const fallWords = { waiting: 'session.pallet_waiting', falling: 'session.pallet_falling', down: 'session.pallet_down' };
    const hazards = [
      ...(state && state.pedestrians ? state.pedestrians : []).map((p) => ({ id: p.id, kind: 'pedestrian', activity: p.activity,
        label: t('session.start_pedestrian', { id: p.id }), done: t('session.pedestrian_out', { id: p.id }), status: `${p.id}: ${words(p.activity)}` })),
      ...(state && state.trucks ? state.trucks : []).map((o) => ({ id: o.id, kind: 'truck', activity: o.activity,
        label: t('session.start_truck', { id: o.id }), done: t('session.truck_out', { id: o.id }), status: `${o.id}: ${words(o.activity, true)}` })),
      ...(plan && plan.falling_pallets ? plan.falling_pallets : []).map((f, i) => {
        const activity = landed.has(i) ? 'down' : fell.has(i) ? 'falling' : 'waiting';
        return { id: f.pallet, kind: 'falling pallet', activity,
                 label: t('session.drop_pallet', { id: f.pallet }), done: t('session.pallet_falls', { id: f.pallet }),
                 status: t(fallWords[activity], { id: f.pallet }) };
      }),
      ...(plan && plan.spills ? plan.spills : []).flatMap((p, i) => p.triggered ? [{ id: p.id, kind: 'spill', activity: spilt.has(i) ? 'on_floor' : 'waiting',
        label: t('session.spill_now', { id: p.id }), done: t('session.spill_appears', { id: p.id }),
        status: t(spilt.has(i) ? 'session.spill_on_floor' : 'session.spill_waiting', { id: p.id }) }] : []),
    ];
    document.getElementById('hazards').hidden = !(s.state === 'running' && s.mode === 'training' && hazards.length > 0);
    for (const h of hazards) {
      let item = hazardItems.get(h.id);
      if (!item) {
        const status = el('span', { class: 'small' });
        const attr = h.kind === 'pedestrian' ? 'data-pedestrian' : 'data-hazard';
        const button = el('button', { type: 'button', class: 'secondary', [attr]: h.id }, h.label);
        button.addEventListener('click', () => {
          if (button.getAttribute('aria-disabled') === 'true') return;
          instruct({ action: 'hazard', hazard: h.id }, h.done);
        });
        item = { li: el('li', { [attr]: h.id, 'data-kind': h.kind }, button, ' ', status), button, status };
        hazardItems.set(h.id, item);
        document.getElementById('hazard-list').append(item.li);
      }
      item.status.textContent = h.status;
      item.li.dataset.activity = h.activity;
      item.button.setAttribute('aria-disabled', h.activity === 'waiting' ? 'false' : 'true');
    }
  }

  // The instructor's hand on a running training session (an exam is only watched, or aborted):
  // pause and resume, a line of text for the pupil's display, and a rewind to try again.
  let pausedNow = false;
  function instructorControls(s, state) {
    const box = document.getElementById('instructor');
    box.hidden = !(s.state === 'running' && s.mode === 'training' && state);
    pausedNow = !!(state && state.paused);
    const b = document.getElementById('pause');
    b.textContent = t(pausedNow ? 'session.resume' : 'session.pause');
    b.setAttribute('aria-pressed', pausedNow ? 'true' : 'false');
  }
  async function instruct(body, done) {
    try {
      await api('POST', `/sessions/${encodeURIComponent(id)}/instructor`, body);
      say(message, done, 'status');
      if (shown) await live(shown);
      return true;
    } catch (e) { say(message, describeError(e)); return false; }
  }
  document.getElementById('pause').addEventListener('click', () =>
    instruct({ action: pausedNow ? 'resume' : 'pause' }, t(pausedNow ? 'session.runs_again' : 'session.paused')));
  document.getElementById('rewind').addEventListener('click', () => {
    const seconds = Number(document.getElementById('rewind-s').value);
    instruct({ action: 'rewind', seconds }, t('session.goes_back', { seconds }));
  });
  document.getElementById('say-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    const input = document.getElementById('say-text');
    const text = input.value.trim();
    if (!text) return;
    instruct({ action: 'message', text }, t('session.message_shown')).then((sent) => { if (sent) input.value = ''; });
  });
  async function live(s) {
    const box = document.getElementById('live');
    const running = isStaff(me) && (s.state === 'waiting' || s.state === 'running');
    box.hidden = !running;
    if (!running) liveState = null;
    if (!running || liveBusy) return;
    liveBusy = true;
    try {
      const v = await api('GET', `/sessions/${encodeURIComponent(s.id)}/live`);
      const dl = clear(document.getElementById('live-state'));
      if (v.state) {
        fact(dl, t('session.time'), t('session.s', { s: num(v.state.sim_time_s) }));
        fact(dl, t('session.time_left'), v.state.time_left_s === null || v.state.time_left_s === undefined ? el('span', { class: 'muted' }, t('session.no_limit'))
          : el('span', { id: 'live-time-left' }, minutesSeconds(v.state.time_left_s)));
        const task = v.state.task;
        if (task && task.steps_total > 0) {
          fact(dl, t('session.task'), el('span', { id: 'live-task' }, t('session.steps', { done: task.steps_done, total: task.steps_total }),
            task.step ? el('span', {}, FL.tAround('session.now_step', 'step', FL.english(task.step))) : t('session.all_done')));
        }
        fact(dl, t('session.speed_label'), `${num(v.state.speed_m_s, 2)} m/s`);
        fact(dl, t('session.forks'), `${num(v.state.lift_m, 2)} m`);
        fact(dl, t('session.load'), v.state.load_attached ? t('session.load_kg', { mass: num(v.state.load_mass_kg, 0) }) : t('session.load_none'));
        fact(dl, t('session.stability'), pct(v.state.stability_margin));
        if (v.state.deadman) fact(dl, t('session.dead_man'), badge('failed', t('session.cab_silent')));
        if (v.state.paused) fact(dl, t('session.paused_label'), el('span', { id: 'live-paused' }, badge('waiting', t('session.paused_by'))));
        if (v.state.instructor_message) fact(dl, t('session.cab_shows'), el('span', { id: 'live-said' }, v.state.instructor_message));
        if (v.state.pedestrians && v.state.pedestrians.length) fact(dl, t('session.pedestrians'), el('span', { id: 'live-people' }, peopleWords(v.state.pedestrians)));
      } else {
        fact(dl, t('session.truck'), t('session.waiting_cab'));
      }
      instructorControls(s, v.state);
      hazardControls(s, v.state);
      liveState = v.state;
      drawLive();
      if (!v.frame_available && !liveUrl) fact(dl, t('session.view'), el('span', { class: 'muted' }, t('session.no_frames')));
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

  let shown = null;  // the session as last fetched
  const lang = await FL.wordPage('session.title', ['certificate']);  // its events worded by the server in it too
  if (!id) { say(message, t('session.which')); return; }
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
