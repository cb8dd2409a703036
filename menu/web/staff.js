// The staff page (admins): GET /api/users by full name, a page at a time with the total; POST
// /api/users to add an account; a new password (POST /api/users/{id}/password) and deactivation or
// reactivation (POST /api/users/{id}/deactivate, /reactivate), each audited by the server.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, t } = FL;
  const me = requireLogin(['admin']);
  const PAGE = 50;
  const ROLES = ['admin', 'instructor', 'examiner', 'pupil'];
  const tbody = document.querySelector('#staff tbody');
  const count = document.getElementById('count');
  const message = document.getElementById('message');
  const previous = document.getElementById('previous'), next = document.getElementById('next');
  const filterRole = document.getElementById('filter-role'), filterActive = document.getElementById('filter-active');
  const filterPupils = document.getElementById('filter-pupils');
  let offset = 0;

  function query() {
    const q = new URLSearchParams({ limit: PAGE, offset });
    if (filterRole.value) q.set('role', filterRole.value);
    if (filterActive.value) q.set('active', filterActive.value);
    if (filterPupils.checked) q.set('include_pupils', 'true');
    return q.toString();
  }

  // A new password typed into the row itself, never shown back.
  function resetForm(u, cell) {
    const id = `password-${u.id}`;
    const input = el('input', { id, type: 'password', autocomplete: 'new-password', minlength: 8, required: true });
    const form = el('form', { class: 'row', 'aria-label': t('staff.new_password_for', { username: u.username }) },
      el('div', {}, el('label', { for: id }, t('staff.new_password_for', { username: u.username })), input),
      el('div', {}, el('button', { type: 'submit' }, t('staff.set_password')),
        ' ', el('button', { type: 'button', class: 'secondary', onclick: list }, t('staff.cancel'))));
    form.addEventListener('submit', async (ev) => {
      ev.preventDefault();
      if (input.value.length < 8) { say(message, t('staff.password_short')); return; }
      try {
        await api('POST', `/users/${encodeURIComponent(u.id)}/password`, { password: input.value });
        say(message, t('staff.password_set', { username: u.username }), 'ok');
        list();
      } catch (e) {
        say(message, describeError(e));
      }
    });
    clear(cell).append(form);
    input.focus();
  }

  async function setActive(u, active) {
    try {
      await api('POST', `/users/${encodeURIComponent(u.id)}/${active ? 'reactivate' : 'deactivate'}`);
      say(message, t(active ? 'staff.reactivated' : 'staff.deactivated_done', { username: u.username }), 'ok');
      list();
    } catch (e) {
      say(message, describeError(e));
    }
  }

  function row(u) {
    const actions = el('td', {});
    actions.append(el('button', { type: 'button', class: 'secondary', 'data-action': 'reset',
                                  onclick: () => resetForm(u, actions) }, t('staff.reset')), ' ');
    if (u.username !== me.username) {
      actions.append(u.active
        ? el('button', { type: 'button', class: 'danger', 'data-action': 'deactivate', onclick: () => setActive(u, false) }, t('staff.deactivate'))
        : el('button', { type: 'button', 'data-action': 'reactivate', onclick: () => setActive(u, true) }, t('staff.reactivate')));
    }
    return el('tr', { 'data-user': u.id },
      el('th', { scope: 'row' }, u.full_name || el('span', { class: 'muted' }, t('staff.no_full_name'))),
      el('td', {}, u.username), el('td', {}, ROLES.includes(u.role) ? t(`staff.roles.${u.role}`) : u.role),
      el('td', {}, el('span', { class: `badge ${u.active ? 'ended' : 'aborted'}` }, t(u.active ? 'staff.active' : 'staff.deactivated'))),
      actions);
  }

  let asked = 0;
  async function list() {
    const mine = ++asked;
    try {
      const page = await api('GET', `/users?${query()}`);
      if (mine !== asked) return;  // a later request has been sent
      if (page.users.length === 0 && offset > 0) { offset = Math.max(0, offset - PAGE); list(); return; }
      clear(tbody).append(...page.users.map(row));
      const what = t('lists.nouns.accounts', { count: page.total });
      count.textContent = page.total === 0 ? t('lists.none', { what })
        : t('lists.count', { from: offset + 1, to: offset + page.users.length, count: page.total, what });
      previous.disabled = offset === 0;
      next.disabled = offset + page.users.length >= page.total;
    } catch (e) {
      say(message, describeError(e));
    }
  }

  for (const f of [filterRole, filterActive, filterPupils]) f.addEventListener('change', () => { offset = 0; list(); });
  previous.addEventListener('click', () => { offset = Math.max(0, offset - PAGE); list(); });
  next.addEventListener('click', () => { offset += PAGE; list(); });

  document.getElementById('add').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    await FL.worded();
    const body = { full_name: document.getElementById('full-name').value.trim(), role: document.getElementById('role').value,
                   username: document.getElementById('new-username').value.trim(),
                   password: document.getElementById('new-password').value };
    if (!body.full_name || !body.username) { say(message, t('staff.needs_names')); return; }
    if (body.password.length < 8) { say(message, t('pupils.need_password')); return; }
    try {
      await api('POST', '/users', body);
      ev.target.reset();
      say(message, t('staff.added', { name: body.full_name, username: body.username }), 'ok');
      list();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  FL.wordPage('staff.title').then(list);
})();
