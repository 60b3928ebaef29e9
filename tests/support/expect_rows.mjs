// Runs a command whose stdout holds JSON rows (one object per line, as `--json` prints them) and
// checks the parsed rows: every --row predicate must hold for at least one row, every --none
// predicate for none, and the command must exit 0. Each failure names the predicate and shows
// the rows. usage: node expect_rows.mjs [--row 'r => ...']... [--none 'r => ...']... -- CMD ARGS...
import { spawnSync } from 'node:child_process';

const args = process.argv.slice(2);
const sep = args.indexOf('--');
if (sep < 0 || sep === args.length - 1) {
  console.error("usage: expect_rows.mjs [--row 'r => ...']... [--none 'r => ...']... -- CMD ARGS...");
  process.exit(2);
}
const want = [], never = [];
for (let i = 0; i < sep; i += 2) {
  const list = args[i] === '--row' ? want : args[i] === '--none' ? never : null;
  if (!list || i + 1 >= sep) {
    console.error(`expect_rows.mjs: bad option ${args[i]}`);
    process.exit(2);
  }
  list.push({ text: args[i + 1], fn: (0, eval)(args[i + 1]) });
}
const run = spawnSync(args[sep + 1], args.slice(sep + 2), { encoding: 'utf8', maxBuffer: 64 << 20 });
process.stdout.write(run.stdout ?? '');
process.stderr.write(run.stderr ?? '');
const rows = [];
for (const line of (run.stdout ?? '').split('\n')) {
  const t = line.trim();
  if (!t.startsWith('{')) continue;
  try { rows.push(JSON.parse(t)); } catch { /* a line that only looks like JSON */ }
}
const failures = [];
if (run.error) failures.push(`cannot run ${args[sep + 1]}: ${run.error.message}`);
else if (run.status !== 0) failures.push(`${args[sep + 1]} exited with ${run.status ?? run.signal}`);
for (const p of want) if (!rows.some((r) => p.fn(r))) failures.push(`no row has ${p.text}`);
for (const p of never) {
  const bad = rows.find((r) => p.fn(r));
  if (bad) failures.push(`a row has ${p.text}: ${JSON.stringify(bad)}`);
}
if (failures.length) {
  console.error(`expect_rows: ${failures.length} expectation(s) failed over ${rows.length} JSON row(s):`);
  for (const f of failures) console.error(`  ${f}`);
  process.exit(1);
}
console.log(`expect_rows: ${want.length + never.length} expectation(s) held over ${rows.length} JSON row(s)`);
