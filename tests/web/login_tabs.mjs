// Logging in once per browser, in Debian's headless Chromium (playwright-core)
// against a real forklift-server on the port forklift-test-alloc gives:
//
//   log in on one page -> a second page of the same browser is logged in -> log out on one: the
//   other goes to the login page -> (a server whose logins last seconds) log in, open two pages:
//   when the token expires both go to the login page, which says so in the one that saw it first
//   -> a page of another browser (context) is never logged in by these.
//
//   BUILD/tests/forklift-test-alloc node login_tabs.mjs --bin BUILD/bin [--chromium /usr/bin/chromium] [--out DIR]
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

let chromium;
try {
  ({ chromium } = await import('playwright-core'));
} catch (e) {
  console.error('login_tabs: playwright-core is missing: run `npm ci --prefix tests/web` (scripts/install-deps.sh does)');
  process.exit(1);
}

const args = { chromium: '/usr/bin/chromium', out: path.resolve('web-login-tabs') };
for (let i = 2; i < process.argv.length; i++) if (process.argv[i].startsWith('--')) args[process.argv[i].slice(2)] = process.argv[++i];
if (!args.bin) { console.error('login_tabs: --bin is required'); process.exit(2); }
const port = Number(process.env.FORKLIFT_TEST_PORT), domain = Number(process.env.FORKLIFT_TEST_DOMAIN);
if (!(port > 0) || !(domain > 0)) {
  console.error('login_tabs: run it as `BUILD/tests/forklift-test-alloc node login_tabs.mjs ...` (ctest does)');
  process.exit(2);
}
const out = path.resolve(args.out);
fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(out, { recursive: true });

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const base = `http://127.0.0.1:${port}`;
const password = 'tabs-admin-pass';
function check(cond, what) { if (!cond) throw new Error(what); }

let server = null;
async function startServer(name, extra) {
  const log = fs.openSync(path.join(out, `${name}.log`), 'w');
  server = spawn(path.join(args.bin, 'forklift-server'),
    ['--db', path.join(out, `${name}.db`), '--listen', `127.0.0.1:${port}`, '--dds-domain', String(domain),
     '--admin-password', password, '--log-dir', path.join(out, `${name}-logs`), ...extra],
    { stdio: ['ignore', log, log] });
  for (let i = 0; i < 400; i++) {
    try { if ((await fetch(base + '/api/health')).ok) return; } catch (e) { /* not up yet */ }
    if (server.exitCode !== null) break;
    await sleep(50);
  }
  throw new Error(`${name}: the server did not come up: ${fs.readFileSync(path.join(out, `${name}.log`), 'utf8')}`);
}
async function stopServer() {
  if (!server || server.exitCode !== null) return;
  const done = new Promise((r) => server.once('exit', r));
  server.kill('SIGTERM');
  await done;
}

const browser = await chromium.launch({ executablePath: args.chromium, headless: true });
const errors = [];
async function newContext() {
  const context = await browser.newContext({ viewport: { width: 1280, height: 860 }, locale: 'en-GB', timezoneId: 'UTC' });
  // "not logged in" is how app.js's requireLogin stops a page it sends to the login page.
  context.on('page', (p) => p.on('pageerror', (e) => { if (e.message !== 'not logged in') errors.push(`${p.url()}: ${e.message}`); }));
  return context;
}
// The page shows a login: the top bar names the user.
async function loggedIn(page) {
  await page.waitForSelector('#top .who', { timeout: 30000 });
  return page.textContent('#top .who');
}
async function logIn(page) {
  await page.goto(base + '/index.html');
  await page.fill('#username', 'admin');
  await page.fill('#password', password);
  await page.click('#login button[type=submit]');
  await page.waitForURL(/fleet\.html/, { timeout: 30000 });
}
const onLoginPage = (page) => page.waitForURL(/\/index\.html/, { timeout: 60000 });

try {
  // ------------------------------------------------ one login for the browser, logged out everywhere
  await startServer('tabs', []);
  let context = await newContext();
  const first = await context.newPage();
  await logIn(first);
  check((await loggedIn(first)).includes('admin'), 'the first page is not logged in');
  const second = await context.newPage();
  await second.goto(base + '/pupils.html');
  check((await loggedIn(second)).includes('admin'), 'a second page of the same browser is not logged in');
  check(/pupils\.html/.test(second.url()), `the second page left for ${second.url()}`);
  // Another browser shares nothing.
  const stranger = await (await newContext()).newPage();
  await stranger.goto(base + '/pupils.html');
  await onLoginPage(stranger);

  // The log-out button on the second page: the first page, not touched, goes to the login page.
  await second.click('#top button');
  await onLoginPage(second);
  await onLoginPage(first);
  check(await first.isVisible('#login'), 'the first page does not show the login form');
  // And the token is ended on the server too: logging in again works and gives a new one.
  const third = await context.newPage();
  await third.goto(base + '/fleet.html');
  await onLoginPage(third);
  await context.close();
  await stopServer();
  console.log('login_tabs: one login per browser, logged out in every page');

  // ------------------------------------------------ the token's expiry honoured in every page
  await startServer('expiry', ['--token-ttl', '20']);
  context = await newContext();
  const a = await context.newPage();
  await logIn(a);
  const b = await context.newPage();
  await b.goto(base + '/pupils.html');
  check((await loggedIn(b)).includes('admin'), 'a second page is not logged in before the expiry');
  await onLoginPage(a);
  await onLoginPage(b);
  check(await a.isVisible('#login') && await b.isVisible('#login'), 'a page does not show the login form after the expiry');
  // The login page says it once its words have loaded, which a busy machine may take a while over.
  const messages = async () => [await a.textContent('#message'), await b.textContent('#message')].join(' ');
  for (let i = 0; i < 150 && !/expired/.test(await messages()); ++i) await a.waitForTimeout(100);
  const said = await messages();
  check(/expired/.test(said), `neither login page says the login expired: "${said}"`);
  // A page opened now is not logged in either.
  const c = await context.newPage();
  await c.goto(base + '/fleet.html');
  await onLoginPage(c);
  console.log('login_tabs: an expired login sends every page to the login page');
  check(errors.length === 0, `page errors: ${errors.join('; ')}`);
  console.log('login_tabs: passed');
} catch (e) {
  console.error(`login_tabs: FAILED: ${e.message}`);
  process.exitCode = 1;
} finally {
  await browser.close();
  await stopServer();
}
