// Shared by every page: the login (one per browser, in localStorage, never in a URL; every tab
// follows it: logged out or expired in one, logged out in all), calls to /api/ with
// its bearer token, elements built from data as text only (never HTML from data), the top bar
// by role, and small formatters. Pages are plain scripts loaded with `defer`; no framework.
'use strict';
// The page's deferred scripts have all run by DOMContentLoaded: from then its forms are handled.
document.addEventListener('DOMContentLoaded', () => document.documentElement.classList.remove('loading'));

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
  // looked up with i18next (vendor/, from npm). Every page calls useLanguage() (most through
  // wordPage()) and words itself with t(); its static text carries a data-i18n attribute naming
  // its text's key, and data-i18n-attr its attributes' ("aria-label:KEY;placeholder:KEY").
  const LANGUAGES = ['en', 'es'];  // data/i18n/'s folders, as server/openapi.yaml's Language
  let i18n = null;

  // The language a page with no login of its own opens in: ?lang=, the login's, the browser's.
  function preferredLanguage() {
    const asked = param('lang'), l = login(), browser = (navigator.language || '').slice(0, 2);
    return [asked, l && l.language, browser].find((x) => LANGUAGES.includes(x)) || 'en';
  }

  // Loads `lang`'s messages of the shared namespace and `namespaces`, then words the page's marked
  // text and its top bar in them. A message missing is said on the console (the tests fail on it).
  let wording = null;  // the latest useLanguage() under way or done
  function useLanguage(lang, namespaces = []) {
    wording = wordIn(lang, namespaces);
    return wording;
  }
  // Settles once the page has its words: a form sent before then waits for them.
  const worded = () => wording || Promise.resolve();

  async function wordIn(lang, namespaces) {
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

  // A page worded in the school's languages: the signed-in person's (English without a login),
  // with the events' words (namespace words) and its title "<page> · <school>" from `titleKey`.
  async function wordPage(titleKey, namespaces = []) {
    const l = login();
    const lang = await useLanguage((l && l.language) || 'en', ['words', ...namespaces]);
    if (titleKey) document.title = t('title', { page: t(titleKey) });
    return lang;
  }

  // Whether the page's language has a message for `key` (data the catalogues word when they can).
  const has = (key) => !!i18n && i18n.exists(key);
  // A truck as the API gives it ({name, title, osha_class}), its title and class in the page's
  // language where the certificate's catalogue words them (a page that loads it).
  function truckWords(tr) {
    const own = (key, english) => (has(`certificate:${key}.${tr.name}`) ? t(`certificate:${key}.${tr.name}`) : english);
    return { ...tr, title: own('trucks', tr.title), osha_class: tr.osha_class ? own('truck_classes', tr.osha_class) : tr.osha_class };
  }

  // A message of the page's language ("certificate:page.print", "nav.fleet" in the shared one).
  function t(key, vars) {
    if (!i18n) throw new Error(`t('${key}') before useLanguage()`);
    return i18n.t(key, vars);
  }
  // The top bar's words: the page's language once it has one, English until then.
  const TOP_ENGLISH = { brand: 'Forklift school', skip: 'Skip to content', pages: 'Pages', log_out: 'Log out',
                        'nav.fleet': 'Fleet', 'nav.pupils': 'Pupils', 'nav.day': 'The day', 'nav.sessions': 'Sessions',
                        'nav.exams': 'Exams', 'nav.start': 'Start a session', 'nav.theory': 'Theory exam', 'nav.staff': 'Staff',
                        'nav.my_record': 'My record', 'nav.certificate': 'Certificate', language: 'Language' };
  // Each language named in itself, as a reader of it looks for it.
  const LANGUAGE_NAMES = { en: 'English', es: 'Español' };
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
      languageChoice(l),
      el('button', { type: 'button', class: 'link', onclick: logout }, top('log_out')));
  }

  // The signed-in person's language, chosen on their own record (staff: their account; a pupil:
  // their pupil record), kept with the login and the page shown again in it.
  function languageChoice(l) {
    const own = l.role === 'pupil' ? (l.pupil_id ? `/pupils/${encodeURIComponent(l.pupil_id)}` : null)
                                   : (l.user_id ? `/users/${encodeURIComponent(l.user_id)}` : null);
    if (!own) return null;  // a login kept before the logins said who: chosen after the next
    const select = el('select', { id: 'language', class: 'language', 'aria-label': top('language') },
      LANGUAGES.map((x) => el('option', { value: x, lang: x, selected: x === (l.language || 'en') }, LANGUAGE_NAMES[x])));
    select.addEventListener('change', async () => {
      try {
        const r = await api('PATCH', own, { language: select.value });
        const now = login();
        if (now && now.token === l.token) setLogin({ ...now, language: r.language || select.value });
        location.reload();
      } catch (e) {
        select.value = l.language || 'en';
        const box = document.getElementById('message');
        if (box) say(box, describeError(e));
      }
    });
    return select;
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

  // The shared words of sessions and events, in the page's language once it has one (English
  // until then): worry levels, outcomes, states and the worker's end reasons (forklift-menu's
  // session vocabulary); a code no catalogue knows yet is still said as words, and a reason the
  // server wrote in words ("aborted by ines") stays as it is.
  const ENGLISH = {
    worry: { 0: 'information', 1: 'minor', 3: 'medium', 5: 'serious' },
    outcome: { open: 'under way', completed: 'completed', timed_out: 'out of time', aborted: 'aborted by the instructor',
               stopped: 'stopped', failed: 'failed' },
    state: { starting: 'starting', waiting: 'waiting for the cab', running: 'running', ended: 'ended', aborted: 'aborted',
             failed: 'failed' },
    reason: { duration: 'its time was up', time_limit: 'the time limit was reached', task_complete: 'the task was done',
              aborted: 'aborted by an instructor', signal: 'stopped before its end', numerical_failure: 'the simulation failed',
              cab_gone: 'the cab stopped sending its controls', parked: 'parked at the end', tipped_over: 'the truck tipped over' },
  };
  const word = (group, code) => {
    if (!Object.prototype.hasOwnProperty.call(ENGLISH[group], code)) return null;
    return i18n ? t(`${group === 'worry' ? 'words:' : ''}${group}.${code}`) : ENGLISH[group][code];
  };
  const asWords = (code) => String(code).replace(/_/g, ' ');
  function outcomeText(o) { return word('outcome', o) || asWords(o); }
  function stateText(s) { return word('state', s) || asWords(s); }
  function reasonText(r) {
    return word('reason', r) || (/^[a-z]+(_[a-z]+)+$/.test(r) ? asWords(r) : String(r));
  }
  // A worry level's class for its colour: always the English word (style.css's).
  function worryClass(level) { return ENGLISH.worry[level] || `level-${level}`; }
  function worryName(level) { return word('worry', level) || (i18n ? t('words:worry.other', { level }) : `level ${level}`); }

  // Why a result is not a pass (the API's {code, text}), in the page's language: the server's text
  // in English; a code with a message of its own in another language, worded from the text's
  // numbers and the session's end reason; any other kept as the server wrote it, marked English.
  function reasonWords(r, endReason) {
    if (!i18n || i18n.language === 'en') return r.text;
    const because = endReason ? t('why.because', { reason: reasonText(endReason) }) : '';
    const points = /^(\d+) penalty points, more than the (\d+) allowed$/.exec(r.text);
    if (['aborted', 'stopped', 'failed'].includes(r.code) && /before its end|failed/.test(r.text)) return t(`why.${r.code}`) + because;
    if (r.code === 'timed_out' && /^the paper's/.test(r.text)) return t('why.paper_timed_out');
    if (r.code === 'timed_out') return t(/time limit/.test(r.text) ? 'why.time_limit' : 'why.timed_out');
    if (r.code === 'too_many_points' && points) return t('why.too_many_points', { points: points[1], allowed: points[2] });
    if (r.code === 'evidence' && /no exam session/.test(r.text)) return t('why.no_session');
    if (['task_incomplete', 'not_passed', 'no_score'].includes(r.code)) return t(`why.${r.code}`);
    return english(r.text);
  }

  // Words the data gives only in English (a scenario's description, a rule's source, the theory
  // bank's questions) on a page in another language: said as English, so that a reader and a
  // screen reader know it.
  function english(text) {
    return !i18n || i18n.language === 'en' || !text ? text : el('span', { lang: 'en' }, text);
  }

  // A message whose variable `name` is a node (English data, a link): the message's text around it.
  function tAround(key, name, node, vars = {}) {
    const [before, after] = t(key, { ...vars, [name]: '\u0000' }).split('\u0000');
    return [before, node, after];
  }

  // A message in a live region: errors are announced, and never built from HTML.
  function say(node, text, kind = 'error') {
    clear(node).append(el('p', { class: kind, role: kind === 'error' ? 'alert' : 'status' }, text));
  }

  // What went wrong in the server's words; its code is for scripts, not for the person reading.
  // The server (and the browser) words it in English: said as English on a page in another
  // language (english()), so a node there; tAround() puts it inside a message.
  function describeError(e) {
    if (i18n && e instanceof ApiError && e.code === 'network') return t('error.network');
    if (e instanceof ApiError && e.status && !e.message) return i18n ? t('error.refused', { status: e.status }) : `the server refused it (HTTP ${e.status})`;
    return english(String((e && e.message) || e));
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
           useLanguage, wordPage, worded, preferredLanguage, t, has, truckWords, LANGUAGES,
           dateTime, day, pct, num, worryName, worryClass, reasonWords, english, tAround, outcomeText, stateText, reasonText, say, describeError, poll, STAFF };
})();
