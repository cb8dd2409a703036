// Shared by every page: the login (one per browser, in localStorage, never in a URL; every tab
// follows it: logged out or expired in one, logged out in all), calls to /api/ with
// its bearer token, elements built from data as text only (never HTML from data), the top bar
// by role, and small formatters. Pages are plain scripts loaded with `defer`; no framework.
'use strict';

const FL = (() => {
  const KEY = 'forklift.login';
  const STAFF = ['admin', 'instructor', 'examiner'];

  // The browser's login, shared by its tabs: an instructor watching four cabs
  // logs in once. On a school's shared PC "Log out" in any tab ends it in every tab (and on the
  // server); an expired one is removed by the first tab that sees it.
  function stored() {
    try {
      return JSON.parse(localStorage.getItem(KEY));
    } catch (e) {
      return null;  // unreadable: treated as logged out
    }
  }

  function login() {
    const l = stored();
    if (l && l.token && l.expires_at > Date.now()) return l;
    if (l) localStorage.removeItem(KEY);  // expired: every other tab hears it and goes to the login
    return null;
  }

  function setLogin(l) { localStorage.setItem(KEY, JSON.stringify(l)); }
  function clearLogin() { localStorage.removeItem(KEY); }
  // Only the login `l` itself: a tab holding an older token must not end a newer login.
  function clearLoginOf(l) {
    const now = stored();
    if (!now || now.token === l.token) clearLogin();
  }

  // This page, as the login page's `next` (it comes back here afterwards).
  const here = () => location.pathname.replace(/^\//, '') + location.search;

  // A page shown for login `l` leaves when that login ends, in this tab or another: logged out
  // (to the login page), expired (the same, saying so), or replaced by another user's (reloaded
  // for them).
  function followLogin(l) {
    const expired = () => {
      clearLoginOf(l);
      location.replace('index.html?expired=1&next=' + encodeURIComponent(here()));
    };
    const check = () => {
      const now = stored();
      if (!now || !now.token) location.replace('index.html?next=' + encodeURIComponent(here()));
      else if (now.token !== l.token) location.reload();
      else if (now.expires_at <= Date.now()) expired();
    };
    window.addEventListener('storage', (ev) => { if (ev.key === KEY || ev.key === null) check(); });
    // A background tab's timers may run late: look again whenever it is shown.
    document.addEventListener('visibilitychange', () => { if (!document.hidden) check(); });
    setTimeout(expired, Math.min(Math.max(0, l.expires_at - Date.now()), 2 ** 31 - 1));
  }

  class ApiError extends Error {
    constructor(status, code, message) {
      super(message);
      this.status = status;
      this.code = code;
    }
  }

  // One call to the API. JSON in and out (a Blob for anything else); throws ApiError with the
  // server's error code and message. A 401 on a page that needs a login goes back to the login.
  async function api(method, path, body) {
    const l = login();
    const headers = { Accept: 'application/json' };
    if (l) headers.Authorization = 'Bearer ' + l.token;
    const init = { method, headers, cache: 'no-store' };
    if (body !== undefined) {
      headers['Content-Type'] = 'application/json';
      init.body = JSON.stringify(body);
    }
    let res;
    try {
      res = await fetch('/api' + path, init);
    } catch (e) {
      throw new ApiError(0, 'network', 'the server cannot be reached');
    }
    const type = res.headers.get('Content-Type') || '';
    const data = type.includes('application/json') ? await res.json() : await res.blob();
    if (!res.ok) {
      const err = data && data.error ? data.error : { code: 'error', message: res.statusText };
      if (res.status === 401 && l) {
        clearLoginOf(l);
        location.assign('index.html?expired=1');
      }
      throw new ApiError(res.status, err.code, err.message);
    }
    return data;
  }

  // An element: attributes (class, for, aria-*, ...) set as attributes, `on*` functions as
  // listeners, children as nodes or text. Text from data always goes in as text nodes.
  function build(ns, tag, attrs, children) {
    const e = ns ? document.createElementNS(ns, tag) : document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === null || v === undefined || v === false) continue;
      if (k.startsWith('on') && typeof v === 'function') e.addEventListener(k.slice(2), v);
      else if (k === 'text') e.textContent = String(v);
      else e.setAttribute(k, v === true ? '' : String(v));
    }
    for (const c of children.flat()) {
      if (c === null || c === undefined || c === false) continue;
      e.append(c instanceof Node ? c : document.createTextNode(String(c)));
    }
    return e;
  }
  const el = (tag, attrs, ...children) => build(null, tag, attrs, children);
  const SVG = 'http://www.w3.org/2000/svg';
  const svg = (tag, attrs, ...children) => build(SVG, tag, attrs, children);

  function clear(node) {
    while (node.firstChild) node.removeChild(node.firstChild);
    return node;
  }

  const isStaff = (l) => !!l && STAFF.includes(l.role);

  // The login this page needs, or back to the login page (which returns here afterwards).
  function requireLogin(roles) {
    const l = login();
    if (!l) {
      location.replace('index.html?next=' + encodeURIComponent(here()));
      throw new Error('not logged in');
    }
    if (roles && !roles.includes(l.role)) {
      location.replace(homeOf(l));
      throw new Error('not for this role');
    }
    topBar(l);
    followLogin(l);
    return l;
  }

  function homeOf(l) {
    return isStaff(l) ? 'fleet.html' : 'pupil.html?id=' + encodeURIComponent(l.pupil_id);
  }

  // The school's languages: the catalogues of data/i18n/ (served at /i18n/<lang>/<namespace>.json),
  // looked up with i18next (vendor/, from npm). A page worded in them calls useLanguage() and
  // words itself with t(); its static text carries data-i18n="key" (its text) and
  // data-i18n-attr="attr:key;..." (attributes). The pages that do not yet stay in English whole.
  const LANGUAGES = ['en', 'es'];  // data/i18n/'s folders, as server/openapi.yaml's Language
  let i18n = null;

  // The language a page with no login of its own opens in: ?lang=, the login's, the browser's.
  function preferredLanguage() {
    const asked = param('lang'), l = login(), browser = (navigator.language || '').slice(0, 2);
    return [asked, l && l.language, browser].find((x) => LANGUAGES.includes(x)) || 'en';
  }

  // Loads `lang`'s messages of the shared namespace and `namespaces`, then words the page's marked
  // text and its top bar in them. A message missing is said on the console (the tests fail on it).
  async function useLanguage(lang, namespaces = []) {
    if (!LANGUAGES.includes(lang)) lang = 'en';
    if (i18n && i18n.language === lang) return lang;
    const ns = ['web', ...namespaces];
    const messages = {};
    await Promise.all(ns.map(async (n) => {
      const res = await fetch(`i18n/${lang}/${n}.json`);
      if (!res.ok) throw new Error(`the messages ${lang}/${n} cannot be loaded (HTTP ${res.status})`);
      messages[n] = await res.json();
    }));
    const next = i18next.createInstance();
    await next.init({ lng: lang, fallbackLng: false, ns, defaultNS: 'web', resources: { [lang]: messages },
                      interpolation: { escapeValue: false }, saveMissing: true,
                      missingKeyHandler: (lngs, n, key) => console.error(`message ${n}:${key} is missing in ${lang}`) });
    i18n = next;
    document.documentElement.lang = lang;
    for (const e of document.querySelectorAll('[data-i18n]')) e.textContent = t(e.dataset.i18n);
    for (const e of document.querySelectorAll('[data-i18n-attr]'))
      for (const pair of e.dataset.i18nAttr.split(';')) {
        const at = pair.indexOf(':');  // "aria-label:certificate:page.qr_label": the attribute, then the key
        e.setAttribute(pair.slice(0, at), t(pair.slice(at + 1)));
      }
    const l = login(), top = document.getElementById('top');
    if (l && top && top.childElementCount) topBar(l);
    return lang;
  }

  // A message of the page's language ("certificate:page.print", "nav.fleet" in the shared one).
  function t(key, vars) {
    if (!i18n) throw new Error(`t('${key}') before useLanguage()`);
    return i18n.t(key, vars);
  }
  // The top bar's words: the page's language once it has one, English on the pages not yet worded.
  const TOP_ENGLISH = { brand: 'Forklift school', skip: 'Skip to content', pages: 'Pages', log_out: 'Log out',
                        'nav.fleet': 'Fleet', 'nav.pupils': 'Pupils', 'nav.day': 'The day', 'nav.sessions': 'Sessions',
                        'nav.exams': 'Exams', 'nav.start': 'Start a session', 'nav.theory': 'Theory exam', 'nav.staff': 'Staff',
                        'nav.my_record': 'My record', 'nav.certificate': 'Certificate' };
  const top = (key) => (i18n ? t(key) : TOP_ENGLISH[key]);

  // The top bar: the pages of this role, who is logged in, and a log-out button.
  function topBar(l) {
    const header = document.getElementById('top');
    if (!header) return;
    const here = location.pathname.split('/').pop() || 'index.html';
    const links = isStaff(l)
      ? [['fleet.html', 'nav.fleet'], ['pupils.html', 'nav.pupils'], ['day.html', 'nav.day'], ['sessions.html', 'nav.sessions'],
         ['exams.html', 'nav.exams'], ['start.html', 'nav.start'], ['theory.html', 'nav.theory'],
         ...(l.role === 'admin' ? [['staff.html', 'nav.staff']] : [])]
      : [['pupil.html?id=' + encodeURIComponent(l.pupil_id), 'nav.my_record'], ['theory.html', 'nav.theory'],
         ['certificate.html?pupil=' + encodeURIComponent(l.pupil_id), 'nav.certificate']];
    const list = el('ul', {},
      links.map(([href, key]) => el('li', {},
        el('a', { href, 'aria-current': href.split('?')[0] === here ? 'page' : null }, top(key)))));
    clear(header).append(
      el('a', { class: 'skip', href: '#main' }, top('skip')),
      el('span', { class: 'brand' }, top('brand')),
      el('nav', { 'aria-label': top('pages') }, list),
      el('span', { class: 'who' }, i18n ? t('who', { username: l.username, role: t(`roles.${l.role}`) }) : `${l.username} (${l.role})`),
      el('button', { type: 'button', class: 'link', onclick: logout }, top('log_out')));
  }

  async function logout() {
    try { await api('POST', '/logout'); } catch (e) { /* the token is dropped here anyway */ }
    clearLogin();
    location.assign('index.html');
  }

  function param(name) { return new URLSearchParams(location.search).get(name); }

  // ISO-8601 UTC from the server, shown in the reader's time zone.
  function dateTime(iso) {
    if (!iso) return '';
    const d = new Date(iso);
    if (isNaN(d)) return iso;
    const p = (n) => String(n).padStart(2, '0');
    return `${d.getFullYear()}-${p(d.getMonth() + 1)}-${p(d.getDate())} ${p(d.getHours())}:${p(d.getMinutes())}`;
  }
  function day(iso) { return iso ? dateTime(iso).slice(0, 10) : ''; }
  // Numbers with the page's decimal separator (a comma in Spanish) once it has a language.
  const decimals = (s) => (i18n ? s.replace('.', t('decimal')) : s);
  function pct(x) { return x === null || x === undefined ? '' : decimals(`${Math.round(x * 1000) / 10} %`); }
  function num(x, digits = 1) { return x === null || x === undefined ? '' : decimals(Number(x).toFixed(digits)); }

  const WORRY = { 0: 'information', 1: 'minor', 3: 'medium', 5: 'serious' };
  // A session's outcome (the API's word) as the pages say it.
  const OUTCOME = { open: 'under way', completed: 'completed', timed_out: 'out of time', aborted: 'aborted by the instructor',
                    stopped: 'stopped', failed: 'failed' };
  function outcomeText(o) { return OUTCOME[o] || String(o).replace(/_/g, ' '); }
  // A session's state and the worker's end reason as forklift-menu says them (the session
  // vocabulary's words()); a reason the server wrote in words ("aborted by ines") stays as it is.
  const STATE = { starting: 'starting', waiting: 'waiting for the cab', running: 'running', ended: 'ended', aborted: 'aborted',
                  failed: 'failed' };
  const REASON = { duration: 'its time was up', time_limit: 'the time limit was reached', task_complete: 'the task was done',
                   aborted: 'aborted by an instructor', signal: 'stopped before its end', numerical_failure: 'the simulation failed',
                   cab_gone: 'the cab stopped sending its controls', parked: 'parked at the end', tipped_over: 'the truck tipped over' };
  function stateText(s) { return STATE[s] || String(s).replace(/_/g, ' '); }
  function reasonText(r) {
    if (REASON[r]) return REASON[r];
    return /^[a-z]+(_[a-z]+)+$/.test(r) ? r.replace(/_/g, ' ') : String(r);  // a code no table knows yet, still as words
  }
  function worryName(level) { return WORRY[level] || `level ${level}`; }

  // A message in a live region: errors are announced, and never built from HTML.
  function say(node, text, kind = 'error') {
    clear(node).append(el('p', { class: kind, role: kind === 'error' ? 'alert' : 'status' }, text));
  }

  // What went wrong in the server's words; its code is for scripts, not for the person reading.
  function describeError(e) {
    if (e instanceof ApiError && e.status && !e.message) return `the server refused it (HTTP ${e.status})`;
    return String((e && e.message) || e);
  }

  // Runs `fn` now and every `ms` until `stop()` returns true; errors are shown, not fatal.
  function poll(fn, ms, stop) {
    let timer = null;
    const tick = async () => {
      try {
        await fn();
      } catch (e) {
        console.warn(e);
      }
      if (!stop || !stop()) timer = setTimeout(tick, ms);
    };
    tick();
    return () => clearTimeout(timer);
  }

  return { api, ApiError, login, setLogin, clearLogin, el, svg, clear, requireLogin, topBar, homeOf, isStaff, param,
           useLanguage, preferredLanguage, t, LANGUAGES,
           dateTime, day, pct, num, worryName, outcomeText, stateText, reasonText, say, describeError, poll, STAFF };
})();
