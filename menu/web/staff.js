// The staff page (admins): GET /api/users by full name, a page at a time with the total; POST
// /api/users to add an account; a new password (POST /api/users/{id}/password) and deactivation or
// reactivation (POST /api/users/{id}/deactivate, /reactivate), each audited by the server.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError } = FL;
  const me = requireLogin(['admin']);
  const PAGE = 50;
  const ROLE = { admin: 'Administrator', instructor: 'Instructor', examiner: 'Examiner', pupil: 'Pupil' };
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
    const form = el('form', { class: 'row', 'aria-label': `New password for ${u.username}` },
      el('div', {}, el('label', { for: id }, `New password for ${u.username}`), input),
      el('div', {}, el('button', { type: 'submit' }, 'Set the password'),
        ' ', el('button', { type: 'button', class: 'secondary', onclick: list }, 'Cancel')));
    form.addEventListener('submit', async (ev) => {
      ev.preventDefault();
      if (input.value.length < 8) { say(message, 'A password needs at least 8 characters.'); return; }
      try {
        await api('POST', `/users/${encodeURIComponent(u.id)}/password`, { password: input.value });
        say(message, `New password set for ${u.username}: their other logins have ended.`, 'ok');
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
      say(message, active ? `${u.username} can log in again.` : `${u.username} is deactivated and logged out.`, 'ok');
      list();
    } catch (e) {
      say(message, describeError(e));
    }
  }

  function row(u) {
    const actions = el('td', {});
    actions.append(el('button', { type: 'button', class: 'secondary', 'data-action': 'reset',
                                  onclick: () => resetForm(u, actions) }, 'Reset password'), ' ');
    if (u.username !== me.username) {
      actions.append(u.active
        ? el('button', { type: 'button', class: 'danger', 'data-action': 'deactivate', onclick: () => setActive(u, false) }, 'Deactivate')
        : el('button', { type: 'button', 'data-action': 'reactivate', onclick: () => setActive(u, true) }, 'Reactivate'));
    }
    return el('tr', { 'data-user': u.id },
      el('th', { scope: 'row' }, u.full_name || el('span', { class: 'muted' }, 'no full name')),
      el('td', {}, u.username), el('td', {}, ROLE[u.role] || u.role),
      el('td', {}, el('span', { class: `badge ${u.active ? 'ended' : 'aborted'}` }, u.active ? 'active' : 'deactivated')),
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
      count.textContent = page.total === 0 ? 'No accounts match.'
        : `${offset + 1}–${offset + page.users.length} of ${page.total} account${page.total === 1 ? '' : 's'}`;
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
    const body = { full_name: document.getElementById('full-name').value.trim(), role: document.getElementById('role').value,
                   username: document.getElementById('new-username').value.trim(),
                   password: document.getElementById('new-password').value };
    if (!body.full_name || !body.username) { say(message, 'A member of staff needs a full name and a user name.'); return; }
    if (body.password.length < 8) { say(message, 'Their password needs at least 8 characters.'); return; }
    try {
      await api('POST', '/users', body);
      ev.target.reset();
      say(message, `Added ${body.full_name} (${body.username}).`, 'ok');
      list();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  list();
})();
