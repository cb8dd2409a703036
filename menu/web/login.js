// The login page: POST /api/login, keep the token for this browser (every tab shares it: app.js),
// go on by role (or to the page that sent us here, if it is one of ours).
'use strict';
(() => {
  const { api, setLogin, login, homeOf, say, describeError, param, t } = FL;
  const message = document.getElementById('message');
  // In the language asked (?lang=), else the browser's: nobody is logged in yet.
  FL.useLanguage(FL.preferredLanguage()).then(() => {
    document.title = t('title', { page: t('login.title') });
    if (param('expired')) say(message, t('login.expired'), 'warn');
  });

  // Only our own pages, never another site: "pupil.html?id=3" yes, "//evil.example" no.
  function safeNext() {
    const next = param('next');
    return next && /^[a-z]+\.html(\?[A-Za-z0-9=&%._-]*)?$/.test(next) ? next : null;
  }

  const already = login();
  if (already) location.replace(safeNext() || homeOf(already));
  // Logged in meanwhile in another tab of this browser: go on as that login.
  window.addEventListener('storage', () => {
    const l = login();
    if (l) location.replace(safeNext() || homeOf(l));
  });

  document.getElementById('login').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    await FL.worded();  // a quick hand may log in before the page's words have come
    const username = document.getElementById('username').value.trim();
    const password = document.getElementById('password').value;
    if (!username || !password) {
      say(message, t('login.enter_both'));
      return;
    }
    try {
      const r = await api('POST', '/login', { username, password });
      const l = { token: r.token, role: r.role, user_id: r.user_id, pupil_id: r.pupil_id, username, language: r.language,
                  expires_at: Date.now() + r.expires_in_s * 1000 };
      setLogin(l);
      location.assign(safeNext() || homeOf(l));
    } catch (e) {
      say(message, e.code === 'bad_credentials' ? t('login.bad_credentials') : describeError(e));
    }
  });
})();
