// The sessions page: GET /api/sessions, today's by default (the server's days are UTC), filtered
// by cab, instructor, day, scenario, mode, result and pupil, sorted by a column, a page at a time
// with the total, and the whole filtered list as CSV.
'use strict';
(() => {
  const { api, el, requireLogin, dateTime, num, param, outcomeText, t } = FL;
  const me = requireLogin(FL.STAFF);
  const $ = (id) => document.getElementById(id);
  $('date').value = param('date') || FL_LIST.today();
  $('cab').value = param('cab') || '';

  const list = FL_LIST.pagedList({
    path: '/sessions', key: 'sessions', table: $('sessions'), count: $('count'), previous: $('previous'),
    next: $('next'), message: $('message'), csv: $('csv'), sort: 'created_at', order: 'desc',
    filters: () => ({ date: $('date').value, cab: $('cab').value.trim(), instructor: $('instructor').value, scenario: $('scenario').value,
                      mode: $('mode').value, result: $('result').value, search: $('search').value.trim() }),
    row: (s) => el('tr', { 'data-session': s.id },
      el('td', {}, el('a', { href: `session.html?id=${encodeURIComponent(s.id)}` }, dateTime(s.created_at))),
      el('th', { scope: 'row' }, el('a', { href: `pupil.html?id=${encodeURIComponent(s.pupil_id)}` }, s.pupil_name)),
      el('td', {}, s.cab_id), el('td', {}, s.scenario), el('td', {}, t(`mode.${s.mode}`)),
      el('td', {}, s.started_by ? s.started_by.name || s.started_by.username : ''),
      el('td', {}, el('span', { class: `badge ${s.outcome === 'completed' ? (s.passed === false ? 'not-passed' : 'passed') : s.outcome}` },
        outcomeText(s.outcome), s.passed === true ? t('comma_passed') : s.passed === false ? t('comma_not_passed') : '')),
      el('td', { class: 'num' }, num(s.mark, 1))),
  });

  async function choices() {
    try {
      const [fleet, scenarios] = await Promise.all([api('GET', '/fleet'), api('GET', '/scenarios')]);
      $('cab-list').append(...fleet.cabs.map((c) => el('option', { value: c.id })));
      $('scenario').append(...scenarios.map((s) => el('option', { value: s.name }, s.name)));
      if (me.role === 'admin') {
        const staff = (await api('GET', '/users?limit=1000')).users;
        $('instructor').append(...staff.map((u) => el('option', { value: u.id }, u.full_name || u.username)));
      }
    } catch (e) {
      console.warn(e);
    }
  }

  let timer = null;
  $('search').addEventListener('input', () => { clearTimeout(timer); timer = setTimeout(list.reload, 200); });
  for (const id of ['date', 'cab', 'instructor', 'scenario', 'mode', 'result']) $(id).addEventListener('change', list.reload);
  $('filters').addEventListener('submit', (ev) => { ev.preventDefault(); list.reload(); });
  FL.wordPage('sessions.title').then(() => {
    list.load();
    choices();
  });
})();
