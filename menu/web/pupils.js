// The pupils page: GET /api/pupils?search= as the name is typed; POST /api/pupils to add one.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, day } = FL;
  const me = requireLogin(FL.STAFF);
  const tbody = document.querySelector('#pupils tbody');
  const count = document.getElementById('count');
  const search = document.getElementById('search');
  const message = document.getElementById('message');
  if (me.role === 'examiner') document.getElementById('add').hidden = document.getElementById('add-heading').hidden = true;

  let asked = 0;
  async function list() {
    const mine = ++asked;
    const q = search.value.trim();
    try {
      const pupils = await api('GET', `/pupils?limit=200&search=${encodeURIComponent(q)}`);
      if (mine !== asked) return;  // a later search has been sent
      clear(tbody).append(...pupils.map((p) => el('tr', { 'data-pupil': p.id },
        el('th', { scope: 'row' }, el('a', { href: `pupil.html?id=${encodeURIComponent(p.id)}` }, p.name)),
        el('td', {}, p.email), el('td', {}, day(p.created_at)))));
      count.textContent = pupils.length === 0 ? (q ? `No pupil's name contains "${q}".` : 'No pupils yet.')
                                              : `${pupils.length} pupil${pupils.length === 1 ? '' : 's'}${q ? ` matching "${q}"` : ''}`;
    } catch (e) {
      say(message, describeError(e));
    }
  }

  let timer = null;
  search.addEventListener('input', () => { clearTimeout(timer); timer = setTimeout(list, 200); });
  document.getElementById('search-form').addEventListener('submit', (ev) => { ev.preventDefault(); list(); });

  document.getElementById('add').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    const body = { name: document.getElementById('name').value.trim(), email: document.getElementById('email').value.trim() };
    const username = document.getElementById('new-username').value.trim();
    const password = document.getElementById('new-password').value;
    if (!body.name) { say(message, 'A pupil needs a name.'); return; }
    if (username) {
      if (password.length < 8) { say(message, 'Their password needs at least 8 characters.'); return; }
      body.username = username;
      body.password = password;
    }
    try {
      const p = await api('POST', '/pupils', body);
      ev.target.reset();
      clear(message).append(el('p', { class: 'ok', role: 'status' }, 'Added ',
        el('a', { href: `pupil.html?id=${encodeURIComponent(p.id)}`, id: 'added-pupil' }, p.name), '.'));
      list();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  list();
})();
