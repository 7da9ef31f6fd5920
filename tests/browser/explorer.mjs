// End-to-end test of the lens explorer (`lensim serve`) in Debian's Chromium, driven headless by
// playwright-core (npm, installed by scripts/install-web-test-deps; no browser download).
// Loads the page, picks each classic lens, moves the aperture and focus sliders, checks that the
// diagram, the numbers (the f-number shown equals `lensim lens info`'s) and the preview change,
// compares two lenses side by side, saves screenshots and prints the page's own timings.
// Exits 77 (ctest: skipped) with the reason when playwright-core or Chromium is not available.
//
//   node tests/browser/explorer.mjs --lensim build/lensim [--out DIR] [--readme-shot FILE]
import { spawn, execFileSync } from 'node:child_process';
import { existsSync, mkdirSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) =>
  (a.startsWith('--') ? [...acc, [a.slice(2), all[i + 1]]] : acc), []));
const lensim = path.resolve(args.lensim || path.join(root, 'build/lensim'));
const outDir = path.resolve(args.out || path.join(root, 'build/explorer-screenshots'));
const chromiumPath = process.env.CHROMIUM || '/usr/bin/chromium';
const classic = ['dgauss.50mm.dat', 'wide.22mm.dat', 'fisheye.10mm.dat', 'telephoto.250mm.dat'];

function skip(reason) {
  console.log(`SKIPPED: ${reason}`);
  process.exit(77);
}

let chromium;
try {
  ({ chromium } = await import('playwright-core'));
} catch (e) {
  skip(`playwright-core is not installed (run scripts/install-web-test-deps): ${e.message}`);
}
if (!existsSync(chromiumPath)) skip(`no Chromium at ${chromiumPath} (apt-get install chromium)`);

let passed = 0, failed = 0;
function check(cond, what) {
  if (cond) { passed++; } else { failed++; console.log(`FAIL: ${what}`); }
}

// The server, on a free port.
const server = spawn(lensim, ['serve', '--port', '0', '--scene', 'scenes/demo/demo.pbrt', '--lenses', 'lenses',
  '--lenses', 'tests/data/lenses'],
  { cwd: root, stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((resolve, reject) => {
  let text = '';
  server.stdout.on('data', (d) => {
    text += d;
    const m = text.match(/http:\/\/[^\s]+/);
    if (m) resolve(m[0]);
  });
  server.on('exit', (code) => reject(new Error(`lensim serve exited with ${code}`)));
  setTimeout(() => reject(new Error('lensim serve did not start in 20 s')), 20000);
});

let browser;
try {
  browser = await chromium.launch({ executablePath: chromiumPath, headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage'] });
} catch (e) {
  server.kill('SIGTERM');
  skip(`Chromium cannot start: ${e.message.split('\n')[0]}`);
}

const lensInfo = (lens, stop, focus) => JSON.parse(execFileSync(lensim,
  ['lens', 'info', path.join(root, 'lenses', lens), '--aperture-diameter', String(stop),
   '--focus-distance', focus, '--film-diagonal', '43.3', '--json'], { encoding: 'utf8' }));

const timings = { optics: [], firstFrame: [], fetch: [], wait: [] };
try {
  mkdirSync(outDir, { recursive: true });
  const page = await browser.newPage({ viewport: { width: 1400, height: 1300 } });
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(e.message));
  // Only this server: the page must work offline.
  const foreign = [];
  page.on('request', (r) => { if (!r.url().startsWith(url)) foreign.push(r.url()); });
  await page.goto(url);
  await page.waitForFunction(() => window.explorer && window.explorer.ready, null, { timeout: 20000 });

  const view = (id) => page.locator(`#view-${id}`);
  const data = (id) => view(id).evaluate((el) => ({ ...el.dataset,
    diagram: el.querySelector('.diagram').innerHTML,
    fText: el.querySelector('.fnumber-value')?.textContent,
    efl: el.querySelector('.efl-value')?.dataset.value,
    eflText: el.querySelector('.efl-value')?.textContent,
    hinge: el.querySelector('.hinge-value')?.dataset.value,
    hingeText: el.querySelector('.hinge-value')?.textContent,
    zoomShown: !el.querySelector('.slider.zoom').hidden && el.querySelector('.slider.zoom').offsetWidth > 0,
    stop: el.querySelector('.stop-value')?.dataset.value,
    focus: el.querySelector('.focus-value')?.dataset.value ?? 'inf',
    plots: [...el.querySelectorAll('.plots .svg')].map((p) => p.innerHTML.length),
    img: el.querySelector('.preview-img').src,
    error: el.querySelector('.error').hidden ? '' : el.querySelector('.error').textContent }));
  // Until the numbers, diagram and plots are those of the current settings and a preview frame
  // of them has arrived.
  async function settled(id, previous) {
    await page.waitForFunction(([sel, prevQ]) => {
      const d = document.querySelector(sel).dataset;
      return d.opticsQuery && d.opticsQuery !== prevQ && d.previewQuery === d.opticsQuery &&
        document.querySelector(`${sel} .lens-select`).value && !document.querySelector(sel).pending;
    }, [`#view-${id}`, previous], { timeout: 30000 });
    const d = await data(id);
    timings.optics.push(Number(d.opticsMs));
    timings.firstFrame.push(Number(d.firstFrameMs));
    timings.fetch.push(Number(d.fetchMs));
    timings.wait.push(Number(d.waitMs));
    return d;
  }
  async function slide(id, cls, value) {
    await view(id).locator(cls).evaluate((el, v) => {
      el.value = String(v);
      el.dispatchEvent(new Event('input', { bubbles: true }));
    }, value);
  }
  function checkFNumber(lens, d) {
    const info = lensInfo(lens, d.stop, d.focus);
    check(d.fText === `f/${info.f_number.toFixed(3)}`,
      `${lens}: f-number shown ${d.fText}, lens info f/${info.f_number.toFixed(3)}`);
  }

  let last = await settled('a', '');
  for (const lens of classic) {
    if (last.lens !== lens) {
      await view('a').locator('.lens-select').selectOption(lens);
      const d = await settled('a', last.opticsQuery);
      check(d.lens === lens && d.opticsQuery.includes(encodeURIComponent(lens)), `${lens}: picked`);
      check(d.diagram.includes('<svg') && d.diagram !== last.diagram, `${lens}: diagram changed`);
      check(d.img !== last.img, `${lens}: preview changed`);
      last = d;
    }
    const kinds = await page.evaluate(() => window.explorer.plotKinds.length);
    check(kinds >= 4 && last.plots.length === kinds && last.plots.every((n) => n > 200),
      `${lens}: every plot drawn (${last.plots.length} of ${kinds})`);
    checkFNumber(lens, last);
    // Stop down: the f-number shown goes up, the bundles in the diagram narrow, the preview changes.
    await slide('a', '.fnumber-slider', 700);
    let d = await settled('a', last.opticsQuery);
    check(d.fText !== last.fText && parseFloat(d.fText.slice(2)) > parseFloat(last.fText.slice(2)),
      `${lens}: f-number went from ${last.fText} to ${d.fText}`);
    check(d.diagram !== last.diagram, `${lens}: diagram follows the aperture`);
    check(d.img !== last.img, `${lens}: preview follows the aperture`);
    checkFNumber(lens, d);
    last = d;
    // Focus closer: the focus and film distance shown change, the diagram and preview too.
    await slide('a', '.focus-slider', 150);
    d = await settled('a', last.opticsQuery);
    check(d.focus !== last.focus && d.focus !== 'inf', `${lens}: focus went from ${last.focus} to ${d.focus}`);
    check(d.diagram !== last.diagram, `${lens}: diagram follows the focus`);
    check(d.img !== last.img, `${lens}: preview follows the focus`);
    checkFNumber(lens, d);
    check(!d.error, `${lens}: no error shown (${d.error})`);
    last = d;
    await page.screenshot({ path: path.join(outDir, `explorer-${lens.replace(/\.dat$/, '')}.png`) });
  }

  // A zoom lens (the second lens folder: ids "1:..."): the zoom slider appears; moving it changes
  // the focal length shown, which is `lens info --focal-length`'s EFL for the focal length asked.
  const zoomLens = '1:nikon_zoom_80_200.zmx', zoomFile = path.join(root, 'tests/data/lenses/nikon_zoom_80_200.zmx');
  check(!last.zoomShown, `${last.lens}: no zoom slider for a lens without configurations`);
  await view('a').locator('.lens-select').selectOption(zoomLens);
  last = await settled('a', last.opticsQuery);
  check(last.zoomShown, 'zoom lens: the zoom slider is shown');
  const positions = [300, 700, 1000];
  for (const pos of positions) {
    await slide('a', '.zoom-slider', pos);
    const d = await settled('a', last.opticsQuery);
    const asked = Number(new URLSearchParams(d.opticsQuery).get('focal'));
    const info = JSON.parse(execFileSync(lensim, ['lens', 'info', zoomFile, '--focal-length', String(asked),
      '--focus-distance', d.focus, '--film-diagonal', '43.3', '--json'], { encoding: 'utf8', stdio: ['ignore', 'pipe', 'ignore'] }));
    check(Math.abs(Number(d.efl) - info.effective_focal_length_mm) < 1e-9 &&
      d.eflText === `${info.effective_focal_length_mm.toFixed(3)} mm`,
      `zoom slider ${pos}: EFL shown ${d.eflText}, lens info ${info.effective_focal_length_mm} for ${asked} mm asked`);
    check(Math.abs(Number(d.efl) - asked) < 1e-6 * asked, `zoom slider ${pos}: EFL ${d.efl} is the ${asked} mm asked`);
    if (pos !== positions[0]) check(d.diagram !== last.diagram && Number(d.efl) > Number(last.efl), `zoom slider ${pos}: longer focal length, diagram changed`);
    // The preview renders the zoom position too: its query carries the focal length, its picture changes.
    check(new URLSearchParams(d.previewQuery).get('focal') === String(asked), `zoom slider ${pos}: the preview asked ${asked} mm`);
    if (pos !== positions[0]) check(d.img !== last.img, `zoom slider ${pos}: preview changed`);
    check(!d.error, `zoom slider ${pos}: no error shown (${d.error})`);
    last = d;
  }
  await page.screenshot({ path: path.join(outDir, 'explorer-zoom.png') });
  // Tilt and shift: the hinge distance shown is `lens info --tilt --shift`'s, and J = f / sin(tilt).
  await view('a').locator('.lens-select').selectOption('dgauss.50mm.dat');
  last = await settled('a', last.opticsQuery);
  check(!last.zoomShown && last.hinge === undefined, 'dgauss: no zoom slider, no hinge before a tilt');
  await slide('a', '.tiltx-slider', -60);
  await slide('a', '.shifty-slider', 50);
  let d = await settled('a', last.opticsQuery);
  {
    const info = JSON.parse(execFileSync(lensim, ['lens', 'info', path.join(root, 'lenses/dgauss.50mm.dat'),
      '--aperture-diameter', String(d.stop), '--focus-distance', d.focus, '--film-diagonal', '43.3',
      '--tilt=-6,0', '--shift=0,5', '--json'], { encoding: 'utf8' }));
    const j = info.tilt_shift.hinge_distance_mm;
    check(d.hinge !== undefined && Math.abs(Number(d.hinge) - j) < 1e-9 && d.hingeText === `${j.toFixed(3)} mm`,
      `tilt: hinge shown ${d.hingeText}, lens info ${j}`);
    const closed = info.effective_focal_length_mm / Math.sin(6 * Math.PI / 180);
    check(Math.abs(Number(d.hinge) - closed) < 1e-6 * closed, `tilt: hinge ${d.hinge} = f / sin 6° = ${closed}`);
    check(d.img.startsWith('data:image/png') && !d.error, `tilt: preview and no error (${d.error})`);
    check(d.diagram.includes('film (tilted/shifted)') && d.diagram.includes('tilt (-6, 0)°, shift (0, 5) mm'),
      'tilt: the diagram draws the tilted and shifted film');
  }
  last = d;
  await slide('a', '.tiltx-slider', -120);
  d = await settled('a', last.opticsQuery);
  check(Number(d.hinge) < Number(last.hinge), `tilt: more tilt, shorter hinge distance (${last.hinge} to ${d.hinge})`);
  await page.screenshot({ path: path.join(outDir, 'explorer-tilt.png') });
  last = d;
  await slide('a', '.tiltx-slider', 0);
  await slide('a', '.shifty-slider', 0);
  last = await settled('a', last.opticsQuery);
  check(last.hinge === undefined, 'tilt back to 0: no hinge shown');
  check(!last.diagram.includes('film (tilted/shifted)'), 'tilt back to 0: the diagram\'s film is upright');

  // Two lenses side by side on the same scene.
  if (last.lens !== 'dgauss.50mm.dat') {
    await view('a').locator('.lens-select').selectOption('dgauss.50mm.dat');
    last = await settled('a', last.opticsQuery);
  }
  await page.locator('#compare').check();
  await page.waitForSelector('#view-b');
  await view('b').locator('.lens-select').selectOption('telephoto.250mm.dat');
  const b = await settled('b', '');
  check(b.lens === 'telephoto.250mm.dat' && b.img.startsWith('data:image/png'), 'compare: second view renders');
  const a = await data('a');
  check(a.img !== b.img && a.diagram !== b.diagram, 'compare: the two views differ');
  // Let both previews refine a little for the picture.
  await page.waitForFunction(() => Number(document.querySelector('#view-b').dataset.previewSpp) >= 4,
    null, { timeout: 30000 });
  await page.screenshot({ path: path.join(outDir, 'explorer-compare.png') });
  if (args['readme-shot']) {
    // The README's picture: both previews refined further.
    await page.waitForFunction(() => ['a', 'b'].every((id) =>
      Number(document.querySelector(`#view-${id}`).dataset.previewSpp) >= 64), null, { timeout: 120000 });
    await page.screenshot({ path: path.resolve(args['readme-shot']), quality: 85 });
  }

  check(pageErrors.length === 0, `no script errors (${pageErrors.join('; ')})`);
  check(foreign.length === 0, `no request leaves the server (${foreign.join(', ')})`);
} catch (e) {
  failed++;
  console.log(`FAIL: ${e.stack || e}`);
} finally {
  await browser.close();
  server.kill('SIGTERM');
}

const med = (xs) => { const s = xs.filter(Number.isFinite).sort((p, q) => p - q); return s.length ? s[Math.floor(s.length / 2)] : NaN; };
const max = (xs) => Math.max(...xs.filter(Number.isFinite));
console.log(`page timings over ${timings.optics.length} updates: diagram+numbers+plots median ${med(timings.optics).toFixed(0)} ms, ` +
  `max ${max(timings.optics).toFixed(0)} ms (of which the /api/view request median ${med(timings.fetch).toFixed(0)} ms, ` +
  `before it median ${med(timings.wait).toFixed(0)} ms); first preview frame median ${med(timings.firstFrame).toFixed(0)} ms, ` +
  `max ${max(timings.firstFrame).toFixed(0)} ms`);
console.log(`screenshots in ${outDir}`);
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
