// The browser end-to-end scripts' shared set-up: their flags, failure reporting, child processes
// logged into the output folder, headless Chromium (SwiftShader WebGL2) with a throw-away profile,
// canvas captures, and clean-ups run in reverse order at the end.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const here = path.dirname(fileURLToPath(import.meta.url));
export const require = createRequire(path.join(here, '..', 'package.json'));

// The value after flag `name` on the command line (before a lone `--`), or def.
export function arg(name, def) {
  const end = process.argv.indexOf('--');
  const i = process.argv.indexOf(name);
  return i > 0 && (end < 0 || i < end) && i + 1 < process.argv.length ? process.argv[i + 1] : def;
}

// A script's harness, its messages prefixed with `label`: the flags --daemon (required), --out,
// --web and --chromium, checked; the output folder made; `cleanups` run by cleanup().
export function harness(label) {
  const started = Date.now();
  const at = () => `${((Date.now() - started) / 1000).toFixed(1)} s`;
  const h = {
    daemonPath: arg('--daemon'),
    outDir: path.resolve(arg('--out', 'e2e-out')),
    webDir: path.resolve(arg('--web', path.join(here, '..', '..', 'web'))),
    chromiumPath: arg('--chromium', '/usr/bin/chromium'),
    cleanups: [],
    die(msg) {
      console.error(`${label}: FAIL (${at()}): ${msg}`);
      process.exitCode = 1;
      throw new Error(msg);
    },
    check(cond, msg) {
      if (!cond) h.die(msg);
      console.log(`${label}: ok (${at()}): ${msg}`);
    },
    async cleanup() {
      while (h.cleanups.length) {
        try { await h.cleanups.pop()(); } catch (e) { console.error(`${label}: cleanup: ${e.message}`); }
      }
    },
    // Starts exe with args (stdout and stderr logged to outDir/name.log, the child told to stop
    // when this process dies); resolves with the first group of re's first match in its output.
    start(name, exe, args, re) {
      const log = fs.openSync(path.join(h.outDir, `${name}.log`), 'w');
      const child = fs.existsSync('/usr/bin/setpriv')
        ? spawn('/usr/bin/setpriv', ['--pdeathsig', 'TERM', '--', exe, ...args], { stdio: ['ignore', 'pipe', 'pipe'] })
        : spawn(exe, args, { stdio: ['ignore', 'pipe', 'pipe'] });
      const exited = new Promise((r) => child.once('exit', r));
      h.cleanups.push(async () => { if (child.exitCode === null) { child.kill('SIGTERM'); await exited; } fs.closeSync(log); });
      return new Promise((resolve, reject) => {
        let text = '';
        const timer = setTimeout(() => reject(new Error(`${name} printed no address in 60 s:\n${text}`)), 60000);
        const onData = (d) => {
          fs.writeSync(log, d);
          text += d.toString();
          const m = re.exec(text);
          if (m) { clearTimeout(timer); resolve(m[1]); }
        };
        child.stdout.on('data', onData);
        child.stderr.on('data', onData);
      });
    },
    // Headless Chromium with SwiftShader WebGL2 and a throw-away profile; resolves with its
    // persistent context (closed by cleanup()).
    async launch(viewport) {
      const playwright = require('playwright-core');
      const profile = fs.mkdtempSync(path.join(os.tmpdir(), `strandcast-${label.replace(/\W+/g, '-')}-`));
      h.cleanups.push(async () => fs.rmSync(profile, { recursive: true, force: true }));
      const context = await playwright.chromium.launchPersistentContext(profile, {
        executablePath: h.chromiumPath,
        headless: true,
        viewport,
        args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
          '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
      });
      h.cleanups.push(async () => context.close());
      return context;
    },
  };
  if (!h.daemonPath || !fs.existsSync(h.daemonPath)) h.die(`--daemon ${h.daemonPath} does not exist`);
  if (!fs.existsSync(h.chromiumPath)) h.die(`${h.chromiumPath} not found; install the Debian package chromium (.ci/deps)`);
  fs.mkdirSync(h.outDir, { recursive: true });
  return h;
}

// The viewer's canvas (window.strandcast.capture) as { width, height, rgba: Buffer }.
export async function capture(page) {
  const c = await page.evaluate(async () => {
    const f = await window.strandcast.capture();
    let s = '';
    for (let i = 0; i < f.rgba.length; i += 0x8000) s += String.fromCharCode.apply(null, f.rgba.subarray(i, i + 0x8000));
    return { width: f.width, height: f.height, b64: btoa(s) };
  });
  return { width: c.width, height: c.height, rgba: Buffer.from(c.b64, 'base64') };
}
