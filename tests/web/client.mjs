// The generated client's test: types generated from server/openapi.yaml by
// openapi-typescript, client/client_test.ts compiled against them by tsc --strict (a call the
// document does not describe fails here), then run with openapi-fetch against a real
// forklift-server on the port forklift-test-alloc gives. Everything comes from tests/web's
// node_modules (npm ci): nothing is downloaded.
//
//   BUILD/tests/forklift-test-alloc node client.mjs --bin BUILD/bin --api server/openapi.yaml [--out DIR]
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = { out: path.resolve('web-client') };
for (let i = 2; i < process.argv.length; i++) if (process.argv[i].startsWith('--')) args[process.argv[i].slice(2)] = process.argv[++i];
for (const need of ['bin', 'api']) if (!args[need]) { console.error(`client: --${need} is required`); process.exit(2); }
const port = Number(process.env.FORKLIFT_TEST_PORT), domain = Number(process.env.FORKLIFT_TEST_DOMAIN);
if (!(port > 0) || !(domain > 0)) {
  console.error('client: run it as `BUILD/tests/forklift-test-alloc node client.mjs ...` (ctest does)');
  process.exit(2);
}
const modules = path.join(here, 'node_modules');
for (const need of ['openapi-typescript', 'openapi-fetch', 'typescript']) {
  if (!fs.existsSync(path.join(modules, need))) {
    console.error(`client: ${need} is missing: run \`npm ci --prefix tests/web\` (scripts/install-deps.sh does)`);
    process.exit(1);
  }
}
const out = path.resolve(args.out);
fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(out, { recursive: true });
fs.symlinkSync(modules, path.join(out, 'node_modules'));  // tsc and node find openapi-fetch from here
fs.writeFileSync(path.join(out, 'package.json'), JSON.stringify({ type: 'module', private: true }));

const node = process.execPath;
const run = (argv) => execFileSync(node, argv, { stdio: 'inherit', cwd: out });
// Generate, then compile: strict, nothing emitted if anything fails to type-check.
run([path.join(modules, 'openapi-typescript/bin/cli.js'), path.resolve(args.api), '-o', path.join(out, 'api.d.ts')]);
fs.copyFileSync(path.join(here, 'client', 'client_test.ts'), path.join(out, 'client_test.ts'));
run([path.join(modules, 'typescript/bin/tsc'), '--strict', '--noEmitOnError', '--target', 'es2022', '--module', 'nodenext',
     '--moduleResolution', 'nodenext', '--skipLibCheck', '--outDir', path.join(out, 'js'), path.join(out, 'client_test.ts')]);

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const base = `http://127.0.0.1:${port}`;
const password = 'client-admin-pass';
const log = fs.openSync(path.join(out, 'server.log'), 'w');
const server = spawn(path.join(args.bin, 'forklift-server'),
  ['--db', path.join(out, 'forklift.db'), '--listen', `127.0.0.1:${port}`, '--dds-domain', String(domain),
   '--admin-password', password, '--log-dir', path.join(out, 'logs')], { stdio: ['ignore', log, log] });
let code = 1;
try {
  let up = false;
  for (let i = 0; i < 400 && !up && server.exitCode === null; i++) {
    try { up = (await fetch(base + '/api/health')).ok; } catch (e) { await sleep(50); }
  }
  if (!up) throw new Error(`the server did not come up: ${fs.readFileSync(path.join(out, 'server.log'), 'utf8')}`);
  process.env.FORKLIFT_URL = base;
  process.env.FORKLIFT_ADMIN_PASSWORD = password;
  await import(path.join(out, 'js', 'client_test.js'));
  code = 0;
} catch (e) {
  console.error(`client: FAILED: ${e.message}`);
} finally {
  const done = new Promise((r) => server.once('exit', r));
  server.kill('SIGTERM');
  await done;
}
process.exit(code);
