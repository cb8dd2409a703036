// The fleet page: GET /api/fleet every second; a session that leaves the fleet is looked up once
// more (GET /api/sessions/{id}) and listed with how it ended.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, num, poll, stateText, reasonText, t } = FL;
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
    if (s.seconds_since_state === null) return [badge('starting', t('fleet.starting')), t('fleet.first_state')];
    const h = s.healthy ? badge('healthy', t('fleet.healthy')) : badge('unhealthy', t('fleet.no_state'));
    return [h, t('fleet.worker_state', { time: num(s.sim_time_s), speed: num(s.speed_m_s, 2) }),
            s.healthy ? '' : t('fleet.silent', { seconds: num(s.seconds_since_state) })];
  }

  async function abort(id, button) {
    if (!confirmAbort.has(id)) {
      confirmAbort.add(id);
      button.textContent = t('fleet.confirm_abort', { id });
      return;
    }
    try {
      await api('POST', `/sessions/${encodeURIComponent(id)}/abort`);
      say(message, t('fleet.aborted', { id }), 'ok');
    } catch (e) {
      say(message, describeError(e));
    }
    confirmAbort.delete(id);
  }

  function row(c) {
    const s = c.session;
    const status = c.online ? badge('online', t('fleet.online')) : badge('offline', t('fleet.offline'));
    const seen = !c.online && c.last_seen_at ? el('div', { class: 'small muted' }, t('fleet.last_seen', { when: FL.dateTime(c.last_seen_at) })) : null;
    const mode = c.online && c.mode ? el('div', { class: 'small muted' }, t('fleet.controls', { mode: c.mode })) : null;
    if (!s) {
      return el('tr', { 'data-cab': c.id }, el('th', { scope: 'row' }, c.id), el('td', {}, status, seen, mode),
                el('td', { class: 'muted' }, t('fleet.idle')), el('td', {}), el('td', {}), el('td', {}));
    }
    if (!s.id) {
      return el('tr', { 'data-cab': c.id }, el('th', { scope: 'row' }, c.id), el('td', {}, status, seen, mode),
                el('td', { class: 'muted' }, t('fleet.busy')), el('td', {}), el('td', {}), el('td', {}));
    }
    const button = el('button', { type: 'button', class: 'danger', 'data-key': `abort ${s.id}`, 'aria-label': t('fleet.abort_label', { id: s.id }), onclick: (ev) => abort(s.id, ev.currentTarget) },
                      confirmAbort.has(s.id) ? t('fleet.confirm_abort', { id: s.id }) : t('fleet.abort'));
    return el('tr', { 'data-cab': c.id, 'data-session': s.id },
      el('th', { scope: 'row' }, c.id),
      el('td', {}, status, seen, mode),
      el('td', {}, el('a', { href: `session.html?id=${encodeURIComponent(s.id)}` }, s.id), ' ',
         badge(s.state, stateText(s.state)), el('div', { class: 'small' }, `${s.scenario}, ${t(`mode.${s.mode}`)}`)),
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
    if (f.cabs.length === 0) tbody.append(el('tr', {}, el('td', { colspan: 6, class: 'muted' }, t('fleet.no_cab'))));
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
    summary.textContent = t('fleet.summary', { online, cabs: f.cabs.length, workers: f.workers.length, max: f.max_workers });
  }

  FL.wordPage('fleet.title').then(() => poll(refresh, 1000));
})();
