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

// Zoom slider (lenses with configurations): focal length on a log scale between the extreme
// configurations' EFLs; the ends are exactly those EFLs (the server refuses anything outside).
function zoomFor(v) {
  const t = Number(v.zoomSlider.value) / 1000;
  const { min, max } = v.zoom;
  if (t <= 0) return min;
  if (t >= 1) return max;
  return Math.min(max, Math.max(min, min * Math.pow(max / min, t)));
}
function sliderForZoom(v, f) {
  const { min, max } = v.zoom;
  return Math.round(1000 * Math.log(Math.max(min, Math.min(max, f)) / min) / Math.log(max / min));
}
// Tilt (degrees) and shift (mm) sliders: tenths.
const tiltShiftKeys = ['tiltx', 'tilty', 'shiftx', 'shifty'];
function tiltShiftFor(v, key) { return Number(v[`${key}Slider`].value) / 10; }

// The lens file at an aperture and focus (and
// tilted and shifted: tiltShiftQuery).
function previewQuery(v) {
  const f = focusFor(v);
  return `lens=${encodeURIComponent(v.lens)}&fnumber=${fNumberFor(v).toPrecision(6)}` +
         `&focus=${isFinite(f) ? f.toPrecision(6) : 'inf'}&diagonal=${state.scene.film_diagonal_mm}`;
}
// The lens's tilt and shift against the film (the optics and the preview take them).
function tiltShiftQuery(v) {
  let q = '';
  for (const k of tiltShiftKeys) { const x = tiltShiftFor(v, k); if (x !== 0) q += `&${k}=${x}`; }
  return q;
}
// The optics and the preview take the zoom position too.
function query(v) {
  let q = previewQuery(v);
  if (v.zoom) q += `&focal=${zoomFor(v)}`;
  return q + tiltShiftQuery(v);
}

function numbersTable(v, d) {
  const rows = [
    ['Lens', d.lens.name],
    ['Focal length', `<span class="efl-value" data-value="${d.effective_focal_length_mm}">${fmt(d.effective_focal_length_mm, 3)} mm</span>`],
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
  const z = d.zoom;
  if (z) {
    rows.splice(2, 0, ['Zoom', `${z.configurations} configurations, ${fmt(z.min_effective_focal_length_mm)}–${fmt(z.max_effective_focal_length_mm)} mm` +
      (z.requested_focal_length_mm !== undefined ? `; configurations ${z.configuration_a}–${z.configuration_b} at t = ${fmt(z.t, 4)} for ${fmt(z.requested_focal_length_mm, 3)} mm asked` : '')]);
  }
  const ts = d.tilt_shift;
  if (ts) {
    rows.push(['Tilt / shift', `tilt (${ts.tilt_deg.join(', ')})°, shift (${ts.shift_mm.join(', ')}) mm; film reaches ${fmt(ts.film_reach_from_axis_mm)} mm from the axis`]);
    if (ts.hinge_distance_mm !== undefined) {
      rows.push(['Hinge distance', `<span class="hinge-value" data-value="${ts.hinge_distance_mm}">${fmt(ts.hinge_distance_mm, 3)} mm</span> from the front nodal point (J = f / sin ${fmt(ts.tilt_angle_deg, 2)}°)`]);
      rows.push(['Plane of focus', `${fmt(ts.focus_plane_to_film_deg, 2)}° to the film; ` +
        (ts.focus_plane_object_distance_mm === null ? 'meets the axis at infinity' : `meets the axis ${fmt(ts.focus_plane_object_distance_mm / 1000, 3)} m in front of the front principal plane`)]);
    }
  }
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
  const q = query(v);  // reported as what the preview shows beside the optics
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
    if (v.zoom) v.zoomOut.textContent = `${zoomFor(v).toFixed(1)} mm`;
    for (const k of tiltShiftKeys) v[`${k}Out`].textContent = `${tiltShiftFor(v, k)}${k.startsWith('tilt') ? '°' : ' mm'}`;
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
  // A zoom slider only for lenses with configurations; it starts at the file's surface data.
  v.zoom = info.zoom ? { min: info.zoom.min_effective_focal_length_mm, max: info.zoom.max_effective_focal_length_mm } : null;
  v.zoomLabel.hidden = !v.zoom;
  if (v.zoom) v.zoomSlider.value = sliderForZoom(v, info.effective_focal_length_mm);
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
    zoomSlider: $(el, '.zoom-slider'), zoomOut: $(el, '.zoom-out'), zoomLabel: $(el, '.slider.zoom'), zoom: null,
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
  v.zoomSlider.addEventListener('input', () => { v.changedAt ??= performance.now(); schedule(v); });
  for (const k of tiltShiftKeys) {
    v[`${k}Slider`] = $(el, `.${k}-slider`);
    v[`${k}Out`] = $(el, `.${k}-out`);
    v[`${k}Slider`].addEventListener('input', () => { v.changedAt ??= performance.now(); schedule(v); });
  }
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
