// lensim lens explorer: the page. Plain JavaScript, no libraries, nothing from the network but
// this server's API (docs/serve.md).
'use strict';

const $ = (root, sel) => root.querySelector(sel);
const state = { lenses: [], scene: null, plotKinds: [], views: [] };
window.explorer = state;  // for the browser tests

function fmt(x, digits = 2) { return x === null || x === undefined ? '–' : Number(x).toFixed(digits); }
function setStatus(text) { $(document, '#status').textContent = text; }

async function getJson(url, signal) {
  const res = await fetch(url, { signal });
  const body = await res.json();
  if (!res.ok) throw new Error(body.error || res.statusText);
  return body;
}
async function getText(url, signal) {
  const res = await fetch(url, { signal });
  const body = await res.text();
  if (!res.ok) { let m = body; try { m = JSON.parse(body).error; } catch (e) { /* text */ } throw new Error(m); }
  return body;
}

// Aperture slider: f-numbers on a log scale from wide open to 16x (at most f/64).
function fNumberFor(v) {
  const t = Number(v.fSlider.value) / 1000;
  const lo = v.minF, hi = Math.min(64, Math.max(22, lo * 8));
  return lo * Math.pow(hi / lo, t);
}
function sliderForFNumber(v, n) {
  const lo = v.minF, hi = Math.min(64, Math.max(22, lo * 8));
  return Math.round(1000 * Math.log(Math.max(lo, Math.min(hi, n)) / lo) / Math.log(hi / lo));
}
// Focus slider: from just beyond the closest focus to 100 m, log scale; the right end is infinity.
function focusFor(v) {
  const t = Number(v.focusSlider.value);
  if (t >= 1000) return Infinity;
  const lo = v.closest * 1.02, hi = Math.max(100, lo * 10);
  return lo * Math.pow(hi / lo, t / 999);
}
function sliderForFocus(v, d) {
  if (!isFinite(d)) return 1000;
  const lo = v.closest * 1.02, hi = Math.max(100, lo * 10);
  return Math.round(999 * Math.log(Math.max(lo, Math.min(hi, d)) / lo) / Math.log(hi / lo));
}

function query(v) {
  const f = focusFor(v);
  return `lens=${encodeURIComponent(v.lens)}&fnumber=${fNumberFor(v).toPrecision(6)}` +
         `&focus=${isFinite(f) ? f.toPrecision(6) : 'inf'}&diagonal=${state.scene.film_diagonal_mm}`;
}

function numbersTable(v, d) {
  const rows = [
    ['Lens', d.lens.name],
    ['Focal length', `${fmt(d.effective_focal_length_mm)} mm`],
    ['f-number', `<span class="fnumber-value" data-value="${d.f_number}">f/${fmt(d.f_number, 3)}</span>`],
    ['Working f-number', `f/${fmt(d.working_f_number, 3)}`],
    ['Stop diameter', `<span class="stop-value" data-value="${d.stop_diameter_mm}">${fmt(d.stop_diameter_mm, 3)} mm</span> of ${fmt(d.max_stop_diameter_mm, 3)}`],
    ['Entrance pupil', `⌀ ${fmt(d.entrance_pupil_diameter_mm)} mm at z ${fmt(d.entrance_pupil_z_mm)}`],
    ['Exit pupil', `⌀ ${fmt(d.exit_pupil_diameter_mm)} mm at z ${fmt(d.exit_pupil_z_mm)}`],
    ['Focus', d.focus_at_infinity ? '∞' : `<span class="focus-value" data-value="${d.focus_distance_m}">${fmt(d.focus_distance_m, 3)} m</span>`],
    ['Closest focus', `${fmt(d.closest_focus_distance_m, 3)} m`],
    ['Film distance', `${fmt(d.film_distance_mm, 3)} mm`],
    ['Field of view', d.field_of_view_deg === null ? `image circle ⌀ ${fmt(d.image_circle_diameter_mm)} mm` : `${fmt(d.field_of_view_deg)}° diagonal`],
    ['Total track', `${fmt(d.total_track_mm)} mm`],
  ];
  const esc = (t) => String(t).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c]);
  rows[0][1] = esc(rows[0][1]);
  // The lens file's notes and warnings (as `lensim lens info` prints them).
  for (const note of d.diagnostics || []) rows.push(['Note', `<span class="diagnostic">${esc(note)}</span>`]);
  v.table.innerHTML = rows.map(([k, x]) => `<tr><td>${k}</td><td>${x}</td></tr>`).join('');
}

function showError(v, err) {
  v.error.hidden = !err;
  v.error.textContent = err ? String(err.message || err) : '';
}

// Diagram, numbers and plots: one request (/api/view); a newer slider move aborts the older one.
async function updateOptics(v) {
  if (v.opticsCtrl) v.opticsCtrl.abort();
  const ctrl = new AbortController();
  v.opticsCtrl = ctrl;
  const q = query(v);
  const t0 = v.changedAt || performance.now();  // from the slider move
  v.changedAt = null;
  try {
    const tFetch = performance.now();
    const view = await getJson(`/api/view?${q}`, ctrl.signal);
    v.el.dataset.fetchMs = (performance.now() - tFetch).toFixed(1);
    v.el.dataset.waitMs = (tFetch - t0).toFixed(1);
    const info = view.lens;
    const plots = state.plotKinds.map((k) => view.plots[k.name]);
    const diagram = view.diagram;
    numbersTable(v, info);
    v.diagram.innerHTML = diagram;
    state.plotKinds.forEach((k, i) => { $(v.plots, `[data-kind="${k.name}"] .svg`).innerHTML = plots[i]; });
    // Timed to the frame that shows them (after layout and paint).
    await new Promise((resolve) => requestAnimationFrame(() => setTimeout(resolve, 0)));
    if (ctrl.signal.aborted) return;
    const ms = performance.now() - t0;
    v.el.dataset.opticsQuery = q;
    v.el.dataset.opticsMs = ms.toFixed(1);
    v.el.dataset.opticsUpdates = String(Number(v.el.dataset.opticsUpdates || 0) + 1);
    v.timing.textContent = `diagram, numbers and ${plots.length} plots in ${ms.toFixed(0)} ms`;
    v.fOut.textContent = `f/${fmt(info.f_number, 2)}`;
    showError(v, null);
  } catch (err) {
    if (err.name !== 'AbortError') showError(v, err);
  }
}

// The preview: a stream of server-sent events, each frame a PNG with more samples per pixel.
// Starting a new one for this view makes the server cancel the old render.
async function updatePreview(v) {
  if (v.previewCtrl) v.previewCtrl.abort();
  const ctrl = new AbortController();
  v.previewCtrl = ctrl;
  const q = query(v);
  const t0 = performance.now();
  let first = true;
  const exposure = $(document, '#autoexposure').checked ? 'auto' : '0';
  const url = `/api/preview?view=${v.id}&scene=${encodeURIComponent(state.scene.id)}&width=320&spp=256&exposure=${exposure}&${q}`;
  v.pstatus.textContent = 'rendering…';
  try {
    const res = await fetch(url, { signal: ctrl.signal });
    if (!res.ok) throw new Error((await res.json()).error);
    const reader = res.body.getReader();
    const dec = new TextDecoder();
    let buf = '';
    for (;;) {
      const { value, done } = await reader.read();
      if (done) break;
      buf += dec.decode(value, { stream: true });
      let i;
      while ((i = buf.indexOf('\n\n')) >= 0) {
        const block = buf.slice(0, i);
        buf = buf.slice(i + 2);
        const ev = (block.match(/^event: (.*)$/m) || [])[1];
        const data = JSON.parse((block.match(/^data: (.*)$/m) || [])[1] || '{}');
        if (ev === 'frame') {
          v.img.src = `data:image/png;base64,${data.png}`;
          const ms = performance.now() - t0;
          if (first) { v.el.dataset.firstFrameMs = ms.toFixed(1); first = false; }
          v.el.dataset.previewQuery = q;
          v.el.dataset.previewSpp = data.spp;
          v.el.dataset.previewFrames = String(Number(v.el.dataset.previewFrames || 0) + 1);
          v.pstatus.textContent = `${data.width}×${data.height}, ${data.spp} spp, ${(ms / 1000).toFixed(2)} s` +
            (data.exposure_stops ? `, ${data.exposure_stops > 0 ? '+' : ''}${data.exposure_stops.toFixed(1)} EV` : '') +
            (v.el.dataset.firstFrameMs ? ` (first frame ${Number(v.el.dataset.firstFrameMs).toFixed(0)} ms)` : '');
        } else if (ev === 'error') {
          throw new Error(data.error);
        } else if (ev === 'done') {
          v.el.dataset.previewDone = q;
        }
      }
    }
  } catch (err) {
    if (err.name !== 'AbortError') { v.pstatus.textContent = ''; showError(v, err); }
  }
}

// Slider moves are coalesced to one update per animation frame.
function schedule(v) {
  if (v.pending) return;
  v.pending = true;
  requestAnimationFrame(() => {
    v.pending = false;
    const f = focusFor(v);
    v.focusOut.textContent = isFinite(f) ? `${f.toFixed(f < 10 ? 2 : 1)} m` : '∞';
    updateOptics(v);
    updatePreview(v);
  });
}

async function chooseLens(v, id) {
  v.lens = id;
  v.lensSelect.value = id;
  const entry = state.lenses.find((l) => l.id === id);
  v.minF = entry.f_number;
  // The closest focus depends only on the lens: ask once, focused at infinity.
  const info = await getJson(`/api/lens?lens=${encodeURIComponent(id)}&focus=inf&diagonal=${state.scene.film_diagonal_mm}`);
  v.closest = info.closest_focus_distance_m;
  v.el.dataset.lens = id;
  const keepF = v.fWanted || 4;
  v.fSlider.value = sliderForFNumber(v, Math.max(v.minF, keepF));
  v.focusSlider.value = sliderForFocus(v, v.focusWanted || 3);
  schedule(v);
}

function makeView(id, lensId) {
  const el = document.importNode($(document, '#view-template').content, true).firstElementChild;
  el.id = `view-${id}`;
  $(document, '#views').appendChild(el);
  const v = {
    id, el,
    lensSelect: $(el, '.lens-select'), fSlider: $(el, '.fnumber-slider'), fOut: $(el, '.fnumber-out'),
    focusSlider: $(el, '.focus-slider'), focusOut: $(el, '.focus-out'), img: $(el, '.preview-img'),
    pstatus: $(el, '.preview-status'), diagram: $(el, '.diagram'), table: $(el, '.numbers'),
    plots: $(el, '.plots'), timing: $(el, '.timing'), error: $(el, '.error'),
    minF: 2, closest: 0.5, fWanted: null, focusWanted: state.scene.focus_distance_m || 3,
  };
  // Grouped by folder (the catalogue's subfolders: classic lenses at the top level).
  const groups = new Map();
  for (const l of state.lenses) {
    const slash = l.id.lastIndexOf('/');
    const group = slash < 0 ? 'lenses' : l.id.slice(0, slash);
    if (!groups.has(group)) {
      const g = document.createElement('optgroup');
      g.label = group;
      groups.set(group, g);
      v.lensSelect.appendChild(g);
    }
    const o = document.createElement('option');
    o.value = l.id;
    o.textContent = l.error ? `${l.id} (cannot be read)` : `${l.id} — ${l.name}, ${fmt(l.focal_length_mm, 1)} mm f/${fmt(l.f_number, 1)}`;
    o.disabled = !!l.error;
    if (l.error) o.title = l.error;
    groups.get(group).appendChild(o);
  }
  v.plots.innerHTML = state.plotKinds.map((k) =>
    `<figure data-kind="${k.name}"><figcaption>${k.title}</figcaption><div class="svg"></div></figure>`).join('');
  v.lensSelect.addEventListener('change', () => { v.changedAt = performance.now(); chooseLens(v, v.lensSelect.value); });
  v.fSlider.addEventListener('input', () => { v.changedAt ??= performance.now(); v.fWanted = fNumberFor(v); schedule(v); });
  v.focusSlider.addEventListener('input', () => { v.changedAt ??= performance.now(); v.focusWanted = focusFor(v); schedule(v); });
  state.views.push(v);
  chooseLens(v, lensId);
  return v;
}

async function start() {
  try {
    const [info, lenses, scenes] = await Promise.all(
      [getJson('/api/info'), getJson('/api/lenses'), getJson('/api/scenes')]);
    state.lenses = lenses.lenses;
    state.scene = info.scene;
    state.plotKinds = info.plot_kinds;
    const sceneSelect = $(document, '#scene');
    for (const s of scenes.scenes) {
      const o = document.createElement('option');
      o.value = o.textContent = s.id;
      o.selected = s.id === info.scene.id;
      sceneSelect.appendChild(o);
    }
    sceneSelect.addEventListener('change', async () => {
      try {
        state.scene = await getJson(`/api/scene?scene=${encodeURIComponent(sceneSelect.value)}`);
        state.views.forEach(schedule);
      } catch (err) { setStatus(err.message); }
    });
    const usable = state.lenses.filter((l) => !l.error);
    if (!usable.length) { setStatus('no readable lens in the lens folders'); return; }
    const first = usable.find((l) => l.id === info.scene.lens) || usable[0];
    const second = usable.find((l) => l.id !== first.id && /telephoto|wide/.test(l.id)) || usable[0];
    makeView('a', first.id);
    $(document, '#autoexposure').addEventListener('change', () => state.views.forEach((v) => updatePreview(v)));
    const compare = $(document, '#compare');
    compare.addEventListener('change', () => {
      $(document, '#views').classList.toggle('compare', compare.checked);
      if (compare.checked && state.views.length < 2) makeView('b', second.id);
      if (state.views[1]) state.views[1].el.hidden = !compare.checked;
      if (!compare.checked && state.views[1]) fetch('/api/cancel?view=b', { method: 'POST' });
      else if (state.views[1]) schedule(state.views[1]);
    });
    setStatus(`${usable.length} lenses · scene ${info.scene.id} · lensim ${info.version}`);
    state.ready = true;
  } catch (err) {
    setStatus(`cannot start: ${err.message}`);
  }
}

start();
