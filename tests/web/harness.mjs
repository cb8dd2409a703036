// What the browser tests share: their arguments, the processes they start (each with its log in
// the output folder, stopped at the end), the API over fetch, Debian's headless Chromium through
// playwright-core with every page error, console error, failed request and HTTP error caught,
// and numbered steps. Each test file is one script: `setup()` first, then its steps.
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

let chromium;
try {
  ({ chromium } = await import('playwright-core'));
} catch (e) {
  console.error('playwright-core is missing: run `npm ci --prefix tests/web` (scripts/install-deps.sh does)');
  process.exit(1);
}

// axe-core's source, put into a page to run there (the page's own policy allows no script from
// elsewhere; playwright's evaluate is not bound by it).
let axeSource = null;
export async function axeFindings(page) {
  if (!axeSource) {
    try {
      const { createRequire } = await import('node:module');
      axeSource = createRequire(import.meta.url)('axe-core').source;
    } catch (e) {
      throw new Error('axe-core is missing: run `npm ci --prefix tests/web` (scripts/install-deps.sh does)');
    }
  }
  await page.evaluate(axeSource);
  const r = await page.evaluate(async () => window.axe.run(document, { resultTypes: ['violations'] }));
  return {
    // Every violation, by rule and impact; and the serious and critical ones in words, with where.
    all: r.violations.map((v) => `${v.id} ${v.impact}`),
    serious: r.violations.filter((v) => v.impact === 'serious' || v.impact === 'critical').map((v) =>
      `  ${v.id} (${v.impact}): ${v.help}\n` + v.nodes.slice(0, 6).map((n) => `    at ${n.target.join(' ')}: ${n.failureSummary.replace(/\n/g, ' ')}`).join('\n')),
  };
}

// The English a page in another language must not show: every English message of data/i18n whose
// translation in `lang` differs, cut at its variables, each piece with three letters or more.
export function englishMessages(dataDir, lang = 'es', namespaces = ['web', 'words', 'certificate']) {
  const catalogue = (l, ns) => JSON.parse(fs.readFileSync(path.join(dataDir, 'i18n', l, `${ns}.json`), 'utf8'));
  const leaves = (o, prefix = '') => Object.entries(o).flatMap(([k, v]) => (typeof v === 'object' ? leaves(v, `${prefix}${k}.`) : [[prefix + k, v]]));
  const english = new Set();
  for (const ns of namespaces) {
    const other = new Map(leaves(catalogue(lang, ns)));
    for (const [key, text] of leaves(catalogue('en', ns)))
      if (!key.startsWith('_') && other.get(key) !== text)
        for (const piece of text.split(/\{\{[^}]*\}\}/)) if (/[A-Za-z]{3}/.test(piece.trim())) english.add(piece.trim());
  }
  return [...english];
}

// Which of `english` (englishMessages) the page shows: its text, title, the text of its closed
// <details> and the attributes read aloud, whole words only ("exam" is English, "examen" Spanish).
// Taken out first: `names` (people's, the school's, a certificate's number: they stay as they are)
// and what the page marks as another language (lang="en": data the catalogues do not translate).
export function englishLeft(page, english, names = []) {
  const longestFirst = [...new Set(names.filter(Boolean))].sort((a, b) => b.length - a.length);
  return page.evaluate(({ english, names }) => {
    let text = [document.title, document.body.innerText, ...[...document.querySelectorAll('details')].map((d) => d.textContent),
                ...[...document.querySelectorAll('[aria-label],[title],[placeholder],[alt]')].flatMap((e) =>
                  ['aria-label', 'title', 'placeholder', 'alt'].map((a) => e.getAttribute(a) || ''))].join('\n');
    // What the page says is in another language (data not translated, each language's own name).
    for (const e of document.querySelectorAll('body [lang]'))
      if (e.lang !== document.documentElement.lang && e.innerText) text = text.split(e.innerText).join(' ');
    for (const n of names) text = text.split(n).join(' ');
    const escape = (x) => x.replace(/[.*+?^${}()|[\]\\]/g, '\\$&');
    // Each piece found, with what is round it on the page.
    return english.flatMap((piece) => {
      const m = new RegExp(`(?<!\\p{L})${escape(piece)}(?!\\p{L})`, 'u').exec(text);
      return m ? [`${piece} (in "${text.slice(Math.max(0, m.index - 30), m.index + piece.length + 30).replace(/\s+/g, ' ')}")`] : [];
    });
  }, { english, names: longestFirst });
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
export function check(cond, what) { if (!cond) throw new Error(what); }

// --bin and --data are required; the port and DDS domain come from forklift-test-alloc.
export function setup(name) {
  const args = { chromium: '/usr/bin/chromium', out: path.resolve(name) };
  for (let i = 2; i < process.argv.length; i++) {
    const a = process.argv[i];
    if (a === '--headed') args.headed = true;
    else if (a.startsWith('--')) args[a.slice(2)] = process.argv[++i];
  }
  for (const need of ['bin', 'data']) {
    if (!args[need]) { console.error(`${name}: --${need} is required`); process.exit(2); }
  }
  const port = Number(process.env.FORKLIFT_TEST_PORT), domain = Number(process.env.FORKLIFT_TEST_DOMAIN);
  if (!(port > 0) || !(domain > 0)) {
    console.error(`${name}: no FORKLIFT_TEST_PORT and FORKLIFT_TEST_DOMAIN: run it as \`BUILD/tests/forklift-test-alloc node ${name}.mjs ...\` (ctest does)`);
    process.exit(2);
  }
  if (!fs.existsSync(args.chromium)) {
    console.error(`${name}: no Chromium at ${args.chromium}: install Debian's chromium (scripts/install-deps.sh does)`);
    process.exit(1);
  }
  const out = path.resolve(args.out);
  fs.rmSync(out, { recursive: true, force: true });
  fs.mkdirSync(out, { recursive: true });
  return { args, port, domain, out, base: `http://127.0.0.1:${port}` };
}

// A program's --help mentions the flag.
export function supports(binary, flag) {
  try {
    return execFileSync(binary, ['--help'], { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] }).includes(flag);
  } catch (e) {
    return String(e.stdout || '').includes(flag);
  }
}

export class Processes {
  constructor(out) { this.out = out; this.children = []; }
  start(name, binary, argv) {
    const log = fs.openSync(path.join(this.out, `${name}.log`), 'w');
    const child = spawn(binary, argv, { stdio: ['ignore', log, log] });
    child.name = name;
    this.children.push(child);
    return child;
  }
  tail(name, lines = 25) {
    try { return fs.readFileSync(path.join(this.out, `${name}.log`), 'utf8').split('\n').slice(-lines).join('\n'); } catch (e) { return ''; }
  }
  async stopAll() {
    for (const c of this.children.reverse()) {
      if (c.exitCode !== null || c.signalCode !== null) continue;
      c.kill('SIGTERM');
      const done = new Promise((r) => c.once('exit', r));
      if (await Promise.race([done.then(() => true), sleep(5000).then(() => false)]) === false) c.kill('SIGKILL');
    }
  }
}

// A forklift-server of the test's own: a fresh database and logs in the output folder, on the
// test's port and DDS domain, with `adminPassword` for its administrator.
export function startServer(procs, { args, out, base, domain }, adminPassword) {
  return procs.start('server', path.join(args.bin, 'forklift-server'),
    ['--db', path.join(out, 'forklift.db'), '--listen', base.replace('http://', ''), '--dds-domain', String(domain),
     '--admin-password', adminPassword, '--log-dir', path.join(out, 'logs')]);
}

// The JSON API: the body parsed, or an Error naming the call and the answer.
export function apiOf(base) {
  return async function api(method, p, token, body) {
    const res = await fetch(base + '/api' + p, {
      method, headers: { ...(token ? { Authorization: `Bearer ${token}` } : {}), ...(body ? { 'Content-Type': 'application/json' } : {}) },
      body: body ? JSON.stringify(body) : undefined,
    });
    const j = await res.json();
    if (!res.ok) throw new Error(`${method} ${p}: ${res.status} ${JSON.stringify(j)}`);
    return j;
  };
}

export async function waitForServer(base, procs, server) {
  for (let i = 0; i < 100; i++) {
    try { if ((await fetch(base + '/api/health')).ok) return; } catch (e) { /* not yet */ }
    if (server.exitCode !== null) break;
    await sleep(100);
  }
  throw new Error('the server did not come up:\n' + procs.tail('server'));
}

// The browser and one page whose problems (errors of any kind) fail the step they happen in.
export async function browserPage(args, viewport = { width: 1280, height: 860 }) {
  const browser = await chromium.launch({ executablePath: args.chromium, headless: !args.headed });
  const context = await browser.newContext({ viewport, locale: 'en-GB', timezoneId: 'UTC' });
  const page = await context.newPage();
  page.setDefaultTimeout(15000);
  const problems = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => { if (m.type() === 'error') problems.push(`console error on ${page.url()}: ${m.text()}`); });
  page.on('requestfailed', (r) => {
    const why = r.failure() ? r.failure().errorText : '';
    if (!why.includes('ERR_ABORTED')) problems.push(`request failed: ${r.method()} ${r.url()} ${why}`);
  });
  page.on('response', (r) => { if (r.status() >= 400) problems.push(`HTTP ${r.status()} for ${r.request().method()} ${r.url()}`); });
  let stepNo = 0;
  async function step(name, fn) {
    const t0 = Date.now();
    process.stdout.write(`${++stepNo}. ${name} ... `);
    await fn();
    check(problems.length === 0, problems.join('\n'));
    console.log(`ok (${((Date.now() - t0) / 1000).toFixed(1)} s)`);
  }
  return { browser, context, page, problems, step };
}

// A screenshot taker into `dir`. Whole pages are shot by growing the viewport to the page's height
// and back: playwright's own fullPage mode leaves this Chromium clicking at stale coordinates afterwards.
export function shooter(page, dir) {
  return async function shot(name, { fullPage = true, of = page } = {}) {
    const viewport = of.viewportSize();
    if (fullPage) {
      const height = await of.evaluate(() => Math.ceil(document.documentElement.scrollHeight));
      await of.setViewportSize({ width: viewport.width, height: Math.min(Math.max(height, viewport.height), 4000) });
    }
    await of.screenshot({ path: path.join(dir, `${name}.png`), animations: 'disabled' });
    if (fullPage) await of.setViewportSize(viewport);
  };
}

// Logs in on the login page (already open) and waits for the page it leads to.
export async function logInAs(page, username, password, landing) {
  await page.fill('#username', username);
  await page.fill('#password', password);
  await page.click('#login button[type=submit]');
  await page.waitForURL(landing);
}

// A test's end when a step failed: why, the page as it was (<out>/failure.png), what the page
// reported, and `logs` (the tails of the programs' logs); then exit 1.
export async function failed(e, { page, out, problems, browser, procs, logs = '' }) {
  console.log('FAILED');
  console.error(e && e.stack ? e.stack : e);
  try { await page.screenshot({ path: path.join(out, 'failure.png'), fullPage: true }); } catch (x) { /* no page */ }
  if (problems.length) console.error(`problems seen:\n${problems.join('\n')}`);
  console.error(`page: ${page.url()}\n${logs}`);
  await browser.close().catch(() => {});
  await procs.stopAll();
  process.exit(1);
}
