// The fleet page: GET /api/fleet every second; a session that leaves the fleet is looked up once
// more (GET /api/sessions/{id}) and listed with how it ended.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, num, poll, stateText, reasonText } = FL;
  requireLogin(FL.STAFF);
  const tbody = document.querySelector('#cabs tbody');
  const finishedBody = document.querySelector('#finished tbody');
  const summary = document.getElementById('summary');
  const message = document.getElementById('message');
  const running = new Map();   // session id -> what we last saw of it
  const finished = new Set();
  const confirmAbort = new Set();  // sessions whose abort button was pressed once

  function badge(cls, text) { return el('span', { class: `badge ${cls}` }, text); }

  function health(s) {
    if (s.seconds_since_state === null) return [badge('starting', 'starting'), ' waiting for its first state'];
    const h = s.healthy ? badge('healthy', 'healthy') : badge('unhealthy', 'no state');
    return [h, ` t = ${num(s.sim_time_s)} s, ${num(s.speed_m_s, 2)} m/s`,
            s.healthy ? '' : `, silent ${num(s.seconds_since_state)} s`];
  }

  async function abort(id, button) {
    if (!confirmAbort.has(id)) {
      confirmAbort.add(id);
      button.textContent = `Confirm: abort ${id}`;
      return;
    }
    try {
      await api('POST', `/sessions/${encodeURIComponent(id)}/abort`);
      say(message, `Session ${id} aborted.`, 'ok');
    } catch (e) {
      say(message, describeError(e));
    }
    confirmAbort.delete(id);
  }

  function row(c) {
    const s = c.session;
    const status = c.online ? badge('online', 'online') : badge('offline', 'offline');
    const seen = !c.online && c.last_seen_at ? el('div', { class: 'small muted' }, `last seen ${FL.dateTime(c.last_seen_at)}`) : null;
    const mode = c.online && c.mode ? el('div', { class: 'small muted' }, `controls: ${c.mode}`) : null;
    if (!s) {
      return el('tr', { 'data-cab': c.id }, el('th', { scope: 'row' }, c.id), el('td', {}, status, seen, mode),
                el('td', { class: 'muted' }, 'idle'), el('td', {}), el('td', {}), el('td', {}));
    }
    if (!s.id) {
      return el('tr', { 'data-cab': c.id }, el('th', { scope: 'row' }, c.id), el('td', {}, status, seen, mode),
                el('td', { class: 'muted' }, 'busy (another school)'), el('td', {}), el('td', {}), el('td', {}));
    }
    const button = el('button', { type: 'button', class: 'danger', 'data-key': `abort ${s.id}`, 'aria-label': `Abort session ${s.id}`, onclick: (ev) => abort(s.id, ev.currentTarget) },
                      confirmAbort.has(s.id) ? `Confirm: abort ${s.id}` : 'Abort');
    return el('tr', { 'data-cab': c.id, 'data-session': s.id },
      el('th', { scope: 'row' }, c.id),
      el('td', {}, status, seen, mode),
      el('td', {}, el('a', { href: `session.html?id=${encodeURIComponent(s.id)}` }, s.id), ' ',
         badge(s.state, s.state), el('div', { class: 'small' }, `${s.scenario}, ${s.mode}`)),
      el('td', {}, el('a', { href: `pupil.html?id=${encodeURIComponent(s.pupil_id)}` }, s.pupil_name)),
      el('td', { class: 'worker' }, health(s)),
      el('td', {}, button));
  }

  async function sessionEnded(id, seen) {
    finished.add(id);
    let s = seen;
    try {
      s = await api('GET', `/sessions/${encodeURIComponent(id)}`);
    } catch (e) {
      console.warn(e);
    }
    document.getElementById('none-finished').hidden = true;
    finishedBody.prepend(el('tr', { 'data-session': id },
      el('th', { scope: 'row' }, el('a', { href: `session.html?id=${encodeURIComponent(id)}` }, id)),
      el('td', {}, seen.cab),
      el('td', {}, el('a', { href: `pupil.html?id=${encodeURIComponent(seen.pupil_id)}` }, seen.pupil_name)),
      el('td', {}, seen.scenario),
      el('td', { class: 'state' }, el('span', { class: `badge ${s.state}` }, stateText(s.state)), s.reason ? ` (${reasonText(s.reason)})` : ''),
      el('td', { class: 'num' }, s.mark === null || s.mark === undefined ? '–' : num(s.mark))));
  }

  async function refresh() {
    let f;
    try {
      f = await api('GET', '/fleet');
      clear(message);
    } catch (e) {
      say(message, describeError(e));
      return;
    }
    // The table is rebuilt each second: keep the keyboard focus on the same control.
    const focused = document.activeElement && document.activeElement.getAttribute('data-key');
    clear(tbody).append(...f.cabs.map(row));
    if (focused) {
      const again = [...tbody.querySelectorAll('[data-key]')].find((e) => e.getAttribute('data-key') === focused);
      if (again) again.focus();
    }
    if (f.cabs.length === 0) tbody.append(el('tr', {}, el('td', { colspan: 6, class: 'muted' }, 'No cab has announced itself yet: start forklift-cab on a cab station.')));
    const now = new Set();
    for (const c of f.cabs) {
      if (c.session && c.session.id) {
        now.add(c.session.id);
        running.set(c.session.id, { ...c.session, cab: c.id });
      }
    }
    for (const [id, seen] of running) {
      if (!now.has(id) && !finished.has(id)) {
        running.delete(id);
        await sessionEnded(id, seen);
      }
    }
    const online = f.cabs.filter((c) => c.online).length;
    summary.textContent = `${online} of ${f.cabs.length} cabs online; ${f.workers.length} of ${f.max_workers} sim workers running.`;
  }

  poll(refresh, 1000);
})();
