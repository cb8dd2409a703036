// The pupils page: GET /api/pupils a page at a time with the total, searched by name or email,
// filtered by group, sorted by a column, and the whole filtered list as CSV; the add form above the list
// (POST /api/pupils, then PUT /api/pupils/{id}/group); the school's groups (GET/POST /api/groups).
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, day, t } = FL;
  const me = requireLogin(FL.STAFF);
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  if (me.role === 'examiner') $('add-section').hidden = $('add-group').hidden = true;

  const list = FL_LIST.pagedList({
    path: '/pupils', key: 'pupils', table: $('pupils'), count: $('count'), previous: $('previous'),
    next: $('next'), message, csv: $('csv'), sort: 'name', order: 'asc',
    filters: () => ({ search: $('search').value.trim(), group: $('filter-group').value }),
    row: (p) => el('tr', { 'data-pupil': p.id },
      el('th', { scope: 'row' }, el('a', { href: `pupil.html?id=${encodeURIComponent(p.id)}` }, p.name)),
      el('td', {}, p.email), el('td', {}, p.group || ''), el('td', {}, p.instructor ? p.instructor.name || p.instructor.username : ''),
      el('td', {}, day(p.created_at))),
  });

  async function groups() {
    try {
      const g = (await api('GET', '/groups')).groups;
      const options = (sel, first) => clear(sel).append(...first, ...g.map((x) => el('option', { value: x.id }, x.name)));
      const keep = $('filter-group').value;
      options($('filter-group'), [el('option', { value: '' }, t('any')), el('option', { value: '0' }, t('pupils.in_no_group'))]);
      $('filter-group').value = keep;
      options($('new-group'), [el('option', { value: '' }, t('none'))]);
      clear($('groups')).append(...g.map((x) => el('li', {}, t('pupils.group_line', { name: x.name, count: x.pupils }),
        x.instructor ? t('pupils.group_with', { instructor: x.instructor.name || x.instructor.username }) : '')));
      if (!g.length) $('groups').append(el('li', { class: 'muted' }, t('pupils.no_groups')));
    } catch (e) {
      say(message, describeError(e));
    }
  }

  async function instructors() {
    if (me.role !== 'admin') {
      clear($('group-instructor')).append(el('option', { value: '' }, t('pupils.me')));  // the server's default for an instructor
      return;
    }
    try {
      const staff = (await api('GET', '/users?role=instructor&active=true&limit=1000')).users;
      $('group-instructor').append(...staff.map((u) => el('option', { value: u.id }, u.full_name || u.username)));
    } catch (e) {
      console.warn(e);
    }
  }

  let timer = null;
  $('search').addEventListener('input', () => { clearTimeout(timer); timer = setTimeout(list.reload, 200); });
  $('search-form').addEventListener('submit', (ev) => { ev.preventDefault(); list.reload(); });
  $('filter-group').addEventListener('change', list.reload);

  $('add').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    await FL.worded();
    const body = { name: $('name').value.trim(), email: $('email').value.trim() };
    const username = $('new-username').value.trim();
    const password = $('new-password').value;
    const group = $('new-group').value;
    if (!body.name) { say(message, t('pupils.need_name')); return; }
    if (username) {
      if (password.length < 8) { say(message, t('pupils.need_password')); return; }
      body.username = username;
      body.password = password;
    }
    try {
      const p = await api('POST', '/pupils', body);
      if (group) await api('PUT', `/pupils/${encodeURIComponent(p.id)}/group`, { group_id: Number(group) });
      ev.target.reset();
      clear(message).append(el('p', { class: 'ok', role: 'status' }, t('pupils.added_before'),
        el('a', { href: `pupil.html?id=${encodeURIComponent(p.id)}`, id: 'added-pupil' }, p.name), t('pupils.added_after')));
      list.load();
      if (group) groups();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  $('add-group').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    await FL.worded();
    const name = $('group-name').value.trim();
    if (!name) { say(message, t('pupils.group_needs_name')); return; }
    const body = { name };
    if ($('group-instructor').value) body.instructor_id = Number($('group-instructor').value);
    try {
      await api('POST', '/groups', body);
      ev.target.reset();
      say(message, t('pupils.group_added', { name }), 'ok');
      groups();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  FL.wordPage('pupils.title').then(() => {
    list.load();
    groups();
    instructors();
  });
})();
