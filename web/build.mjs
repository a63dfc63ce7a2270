// Builds the dashboard into OUTDIR (default dist/): assets/app-HASH.js and .css (hashed
// names: goniod serves them as immutable) and index.html naming them. The CIE tables come
// from colord-data (--colord DIR), as the twin's do.
//   node build.mjs [--outdir DIR] [--colord DIR] [--no-minify]
import { build } from 'esbuild';
import { mkdir, readFile, rm, writeFile } from 'node:fs/promises';
import { join, basename, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseCgats } from './src/color.js';

const here = dirname(fileURLToPath(import.meta.url));
const arg = (name, fallback) => {
  const i = process.argv.indexOf(name);
  return i > 0 ? process.argv[i + 1] : fallback;
};
const outdir = arg('--outdir', join(here, 'dist'));
const colord = arg('--colord', '/usr/share/colord');
const minify = !process.argv.includes('--no-minify');

const colorTables = {
  name: 'color-tables',
  setup(b) {
    b.onResolve({ filter: /^virtual:color-tables$/ }, () => ({ path: 'color-tables', namespace: 'color' }));
    b.onLoad({ filter: /.*/, namespace: 'color' }, async () => {
      const cmf = parseCgats(await readFile(join(colord, 'cmf', 'CIE1964-10deg-XYZ.cmf'), 'utf8'));
      const illuminant = parseCgats(await readFile(join(colord, 'illuminant', 'CIE-D65.sp'), 'utf8'));
      return { contents: `export default ${JSON.stringify({ cmf, illuminant })};`, loader: 'js' };
    });
  },
};

await rm(join(outdir, 'assets'), { recursive: true, force: true });
await mkdir(join(outdir, 'assets'), { recursive: true });
const result = await build({
  entryPoints: [join(here, 'src', 'main.js')],
  bundle: true,
  format: 'esm',
  target: ['chrome100', 'firefox100', 'safari15'],
  minify,
  sourcemap: false,
  outdir: join(outdir, 'assets'),
  entryNames: 'app-[hash]',
  assetNames: '[name]-[hash]',
  metafile: true,
  legalComments: 'linked',
  logLevel: 'warning',
  plugins: [colorTables],
});
const outputs = Object.keys(result.metafile.outputs).map((p) => basename(p));
const js = outputs.find((f) => f.endsWith('.js'));
const css = outputs.find((f) => f.endsWith('.css'));
if (!js || !css) throw new Error(`build: expected a .js and a .css, got ${outputs.join(', ')}`);
const page = (await readFile(join(here, 'src', 'index.html'), 'utf8'))
  .replace('%JS%', `assets/${js}`).replace('%CSS%', `assets/${css}`);
await writeFile(join(outdir, 'index.html'), page);
console.log(`web: ${outdir}: index.html, ${outputs.map((f) => `assets/${f}`).join(', ')}`);
