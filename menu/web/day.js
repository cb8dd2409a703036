// The day view: GET /api/day, the school's day hour by hour (UTC) down the page and its cabs
// across it, each cell with the bookings and the sessions that ran, names in full and outcomes in
// words; today opens at the current hour. A cab booked (POST /api/bookings, 409 when it is taken
// then), a booking started (POST /api/bookings/{id}/start) or cancelled (DELETE /api/bookings/{id}).
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, param, outcomeText, t } = FL;
  requireLogin(FL.STAFF);
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  $('date').value = param('date') || FL_LIST.today();
  const FIRST_HOUR = 6, LAST_HOUR = 20;
  const hm = (iso) => iso.slice(11, 16);
  const hour = (iso) => Number(iso.slice(11, 13));

  function bookingItem(b) {
    const what = `${b.scenario}${b.mode === 'exam' ? t('day.exam_suffix') : ''}`;
    const item = el('div', { class: 'booking', 'data-booking': b.id, title: t('day.booked', { from: hm(b.starts_at), to: hm(b.ends_at), name: b.pupil.name, what }) },
      `${hm(b.starts_at)}–${hm(b.ends_at)} `, el('strong', {}, b.pupil.name), ` ${what}`);
    if (b.session) {
      item.append(' ', el('a', { href: `session.html?id=${encodeURIComponent(b.session)}` }, b.session));
    } else {
      item.append(' ', el('button', { type: 'button', class: 'link', 'data-action': 'start', onclick: () => start(b) }, t('day.start')),
        ' ', el('button', { type: 'button', class: 'link', 'data-action': 'cancel', onclick: () => cancel(b) }, t('day.cancel')));
    }
    return item;
  }

  function ranItem(s) {
    const outcome = outcomeText(s.outcome);
    return el('div', { class: 'ran', 'data-session': s.id, 'data-outcome': s.outcome, title: `${hm(s.created_at)} ${s.pupil_name}, ${s.scenario}: ${outcome}` },
      `${hm(s.created_at)} `, el('a', { href: `session.html?id=${encodeURIComponent(s.id)}` }, s.pupil_name), ` ${s.scenario}: ${outcome}`);
  }

  async function load() {
    try {
      const d = await api('GET', `/day?date=${encodeURIComponent($('date').value)}`);
      // The day's slots down the page (before the first hour, each hour, from the last), the
      // cabs across: a school has a few cabs and many hours, so the grid fits the page's width.
      const labels = [t('day.before', { hour: FIRST_HOUR })];
      for (let h = FIRST_HOUR; h < LAST_HOUR; ++h) labels.push(`${String(h).padStart(2, '0')}:00`);
      labels.push(t('day.from', { hour: LAST_HOUR }));
      const slot = (iso) => Math.min(Math.max(hour(iso), FIRST_HOUR - 1), LAST_HOUR) - (FIRST_HOUR - 1);
      clear($('grid').querySelector('thead tr')).append(el('th', { scope: 'col', class: 'hour' }, t('day.time')),
        ...d.cabs.map((cab) => el('th', { scope: 'col', 'data-cab': cab }, cab)));
      const cells = labels.map(() => d.cabs.map(() => []));
      for (const b of d.bookings) cells[slot(b.starts_at)][d.cabs.indexOf(b.cab_id)]?.push(bookingItem(b));
      for (const s of d.sessions) cells[slot(s.created_at)][d.cabs.indexOf(s.cab_id)]?.push(ranItem(s));
      const now = new Date().toISOString();
      const current = d.date === now.slice(0, 10) ? slot(now) : -1;
      clear($('grid').querySelector('tbody')).append(...labels.map((label, i) => el('tr', { 'data-slot': i, class: i === current ? 'now' : '' },
        el('th', { scope: 'row', class: 'hour' }, label, i === current ? el('span', { class: 'small' }, t('day.now')) : ''),
        ...cells[i].map((items, c) => el('td', { 'data-cab': d.cabs[c] }, items)))));
      $('summary').textContent = t('day.summary', { date: d.date, bookings: t('day.bookings', { count: d.bookings.length }),
                                                    sessions: t('day.sessions', { count: d.sessions_total }),
                                                    cabs: t('day.cabs', { count: d.cabs.length }) });
      // Today opens at the current hour: the grid scrolls it to its top (the page stays put).
      const row = $('grid').querySelector('tr.now');
      const box = $('grid').parentElement;
      box.scrollTop = 0;
      if (row) box.scrollTop = row.getBoundingClientRect().top - $('grid').querySelector('thead').getBoundingClientRect().bottom;
      clear($('cab-list')).append(...d.cabs.map((c) => el('option', { value: c })));
    } catch (e) {
      say(message, describeError(e));
    }
  }

  async function start(b) {
    try {
      const s = await api('POST', `/bookings/${encodeURIComponent(b.id)}/start`);
      clear(message).append(el('p', { class: 'ok', role: 'status' }, t('day.started', { name: b.pupil.name, cab: b.cab_id }),
        el('a', { href: `session.html?id=${encodeURIComponent(s.id)}`, id: 'started-session' }, s.id), '.'));
      load();
    } catch (e) {
      say(message, describeError(e));
    }
  }

  async function cancel(b) {
    try {
      await api('DELETE', `/bookings/${encodeURIComponent(b.id)}`);
      say(message, t('day.cancelled', { name: b.pupil.name, cab: b.cab_id, time: hm(b.starts_at) }), 'ok');
      load();
    } catch (e) {
      say(message, describeError(e));
    }
  }

  $('book').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    await FL.worded();
    const body = { pupil_id: Number($('pupil').value), cab_id: $('cab').value.trim(), starts_at: `${$('date').value}T${$('start').value}:00Z`,
                   duration_min: Number($('minutes').value), scenario: $('scenario').value, mode: $('mode').value };
    if (!body.pupil_id) { say(message, t('day.choose_pupil')); return; }
    if (!/^[A-Za-z0-9_-]{1,32}$/.test(body.cab_id)) { say(message, t('day.name_cab')); return; }
    try {
      const b = await api('POST', '/bookings', body);
      say(message, t('day.booked_done', { cab: b.cab_id, name: b.pupil.name, from: hm(b.starts_at), to: hm(b.ends_at) }), 'ok');
      load();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  async function choices() {
    try {
      const [scenarios, fleet] = await Promise.all([api('GET', '/scenarios'), api('GET', '/fleet')]);
      $('scenario').append(...scenarios.map((s) => el('option', { value: s.name }, s.name)));
      $('cab-list').append(...fleet.cabs.map((c) => el('option', { value: c.id })));
    } catch (e) {
      console.warn(e);
    }
  }

  FL_LIST.pupilPicker($('pupil-search'), $('pupil'), $('pupil-options'), null, param('pupil'));
  $('date').addEventListener('change', load);
  $('which').addEventListener('submit', (ev) => { ev.preventDefault(); load(); });
  FL.wordPage('day.title').then(() => {
    choices();
    load();
  });
})();
