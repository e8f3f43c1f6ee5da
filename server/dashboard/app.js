// The spindle dashboard: jobs, one job's preview and tile map, workers, actions and submission,
// kept live by the coordinator's event stream. Every call goes to this origin's /v1 API with the
// client token the user gave (sessionStorage, this tab only).

import { readEvents } from './sse.js';
import { blake3Hex } from './blake3.js';

const TOKEN_KEY = 'spindle-token';
/// At most one refetch of a job, its preview and tile map, or the worker list per this period.
const REFRESH_MS = 1000;
const BACKOFF_MIN_MS = 500;
const BACKOFF_MAX_MS = 15000;

const $ = (id) => document.getElementById(id);

const state = {
  jobs: new Map(),
  workers: [],
  selected: null,
  lastEventId: null,
  /// job id → Map(tile index → {worker, seconds}) from tile_done events seen by this page
  /// (`seconds`: the worker's render time).
  tileTimes: new Map(),
  tiles: null,
  stream: null,
  previewUrl: null,
};

// ---- token -----------------------------------------------------------------------------

function token() {
  return sessionStorage.getItem(TOKEN_KEY);
}

/// `/#token=…` (never sent to the server): keep it for this tab, then drop it from the address bar.
function takeTokenFromFragment() {
  const params = new URLSearchParams(location.hash.slice(1));
  const given = params.get('token');
  if (given !== null) {
    if (given) sessionStorage.setItem(TOKEN_KEY, given);
    history.replaceState(null, '', location.pathname + location.search);
  }
}

function showLogin(message) {
  stopEvents();
  sessionStorage.removeItem(TOKEN_KEY);
  state.jobs.clear();
  state.workers = [];
  state.selected = null;
  $('app').hidden = true;
  $('logout').hidden = true;
  $('login').hidden = false;
  $('login-message').textContent = message || '';
  $('token').focus();
}

class Unauthorized extends Error {}

// ---- API -------------------------------------------------------------------------------

/// Calls the API; answers the Response when ok. A 401 brings the token prompt back.
async function call(path, { method = 'GET', body, headers = {} } = {}) {
  const init = { method, headers: { ...headers, Authorization: `Bearer ${token()}` } };
  if (body !== undefined) {
    if (body instanceof Uint8Array || body instanceof Blob) {
      init.body = body;
      init.headers['Content-Type'] = 'application/octet-stream';
    } else {
      init.body = JSON.stringify(body);
      init.headers['Content-Type'] = 'application/json';
    }
  }
  const response = await fetch(path, init);
  if (response.status === 401) {
    const reason = await errorText(response);
    showLogin(`The coordinator refused the token: ${reason}`);
    throw new Unauthorized(reason);
  }
  if (!response.ok) {
    throw new Error(`${method} ${path}: ${response.status} ${await errorText(response)}`);
  }
  return response;
}

async function errorText(response) {
  const text = await response.text();
  try {
    return JSON.parse(text).error || text;
  } catch {
    return text || response.statusText;
  }
}

async function json(path, options) {
  return (await call(path, options)).json();
}

function notice(error) {
  if (error instanceof Unauthorized) return;
  const p = $('notice');
  p.textContent = String(error.message || error);
  p.hidden = false;
  clearTimeout(notice.timer);
  notice.timer = setTimeout(() => { p.hidden = true; }, 8000);
}

/// Runs `f` at most once per REFRESH_MS per key: a call within the period schedules one more
/// run at its end, never more.
const throttles = new Map();
function throttled(key, f) {
  const t = throttles.get(key) || { last: 0, pending: false };
  throttles.set(key, t);
  if (t.pending) return;
  const wait = t.last + REFRESH_MS - Date.now();
  const run = () => {
    t.pending = false;
    t.last = Date.now();
    f().catch(notice);
  };
  if (wait <= 0) run();
  else {
    t.pending = true;
    setTimeout(run, wait);
  }
}

// ---- formatting ------------------------------------------------------------------------

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'class') node.className = v;
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children) if (c !== null && c !== undefined) node.append(c);
  return node;
}

function duration(s) {
  if (s === null || s === undefined || !Number.isFinite(s)) return '–';
  s = Math.round(s);
  if (s < 60) return `${s} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${s % 60} s`;
  return `${Math.floor(s / 3600)} h ${Math.floor((s % 3600) / 60)} min`;
}

function when(ms) {
  const d = new Date(ms);
  const today = new Date().toDateString() === d.toDateString();
  return today ? d.toLocaleTimeString() : d.toLocaleString();
}

function ago(ms) {
  return `${duration(Math.max(0, (Date.now() - ms) / 1000))} ago`;
}

function progress(job) {
  const pct = job.tiles_total ? Math.floor((100 * job.tiles_done) / job.tiles_total) : 0;
  const bar = el('progress', { max: job.tiles_total || 1, value: job.tiles_done });
  return el('span', { class: 'progress' }, bar, ` ${pct}%`);
}

const FINISHED = new Set(['done', 'failed', 'cancelled']);

// ---- jobs ------------------------------------------------------------------------------

async function loadJobs() {
  const filter = $('state-filter').value;
  const jobs = new Map();
  let cursor = null;
  do {
    const query = new URLSearchParams({ limit: '1000' });
    if (filter) query.set('state', filter);
    if (cursor) query.set('cursor', cursor);
    const page = await json(`/v1/jobs?${query}`);
    for (const job of page.jobs) jobs.set(job.id, job);
    cursor = page.next_cursor;
  } while (cursor);
  state.jobs = jobs;
  renderJobs();
}

async function loadJob(id) {
  try {
    const job = await json(`/v1/jobs/${id}`);
    const filter = $('state-filter').value;
    if (!filter || job.state === filter) state.jobs.set(id, job);
    else state.jobs.delete(id);
    renderJobs();
    if (state.selected === id) renderJob(job);
  } catch (e) {
    if (/: 404 /.test(e.message)) {
      state.jobs.delete(id);
      renderJobs();
      if (state.selected === id) closeJob();
    } else throw e;
  }
}

function renderJobs() {
  const rows = [...state.jobs.values()].sort((a, b) => b.id - a.id).map((job) => {
    const lastError = job.error || (job.recent_errors.at(-1) || {}).message || '';
    return el('tr', {
      'data-job': job.id,
      class: job.id === state.selected ? 'selected' : '',
      onclick: () => selectJob(job.id),
    },
    el('td', {}, el('a', { href: '#', onclick: (e) => e.preventDefault() }, job.name)),
    el('td', { class: `state ${job.state}` }, job.state),
    el('td', {}, progress(job)),
    el('td', { class: 'num' }, String(job.priority)),
    el('td', {}, when(job.submitted_at_ms)),
    el('td', {}, duration(job.elapsed_s)),
    el('td', {}, FINISHED.has(job.state) ? '–' : duration(job.eta_s)),
    el('td', { class: 'error clip', title: lastError }, lastError));
  });
  $('jobs-table').tBodies[0].replaceChildren(...rows);
  $('jobs-empty').hidden = rows.length > 0;
}

// ---- one job ---------------------------------------------------------------------------

function selectJob(id) {
  if (state.selected !== id) {
    state.selected = id;
    state.tiles = null;
    buildJobView(id);
  }
  renderJobs();
  refreshSelected(true);
  $('job').scrollIntoView({ block: 'nearest' });
}

function closeJob() {
  state.selected = null;
  $('job').hidden = true;
  $('job').replaceChildren();
  if (state.previewUrl) URL.revokeObjectURL(state.previewUrl);
  state.previewUrl = null;
  renderJobs();
}

/// Refetches the selected job's info, tile map and preview (throttled unless `now`).
function refreshSelected(now = false) {
  const id = state.selected;
  if (id === null) return;
  const work = async () => {
    if (state.selected !== id) return;
    await loadJob(id);
    if (state.selected !== id) return;
    await Promise.all([loadTiles(id), loadPreview(id)]);
  };
  if (now) work().catch(notice);
  else throttled(`job-${id}`, work);
}

function buildJobView(id) {
  const section = $('job');
  section.hidden = false;
  const priority = el('input', { id: 'job-priority-set', type: 'number', step: '1', 'aria-label': 'priority' });
  const act = (name, label, f, title) =>
    el('button', { type: 'button', 'data-action': name, title, onclick: () => f().catch(notice) }, label);
  section.replaceChildren(
    el('div', { class: 'row' },
      el('h2', { id: 'job-title' }, `Job ${id}`),
      el('button', { type: 'button', class: 'close', 'aria-label': 'close', onclick: closeJob }, '×')),
    el('div', { id: 'job-summary', class: 'summary' }),
    el('div', { class: 'actions' },
      act('pause', 'Pause', () => jobAction(id, 'pause')),
      act('resume', 'Resume', () => jobAction(id, 'resume')),
      act('requeue', 'Requeue', () => jobAction(id, 'requeue'), 'render a failed or cancelled job again'),
      act('cancel', 'Cancel', async () => {
        if (window.confirm(`Cancel job ${id}? Its tiles stop being rendered.`)) await jobAction(id, 'cancel');
      }),
      act('delete', 'Delete', () => deleteJob(id)),
      el('span', { class: 'inline' }, priority,
        act('priority', 'Set priority', () => setPriority(id, priority.value))),
      act('png', 'PNG', () => download(`/v1/jobs/${id}/image.png`, `job-${id}.png`)),
      act('exr', 'EXR', () => download(`/v1/jobs/${id}/image.exr`, `job-${id}.exr`))),
    el('div', { class: 'visual' },
      el('figure', {}, el('img', { id: 'preview', alt: 'preview of the tiles received so far' }),
        el('figcaption', {}, 'Preview')),
      el('figure', {}, el('div', { id: 'tilemap', class: 'tilemap' }),
        el('figcaption', {}, 'Tiles: ', el('span', { class: 'key queued' }, 'queued'), ' ',
          el('span', { class: 'key leased' }, 'leased'), ' ', el('span', { class: 'key done' }, 'done'),
          ' ', el('span', { class: 'key failed' }, 'failed')))),
    el('div', { id: 'job-errors' }),
    el('div', { id: 'job-plan' }),
    el('details', {}, el('summary', {}, 'Statistics'), el('table', { id: 'job-stats', class: 'stats' })));
}

async function jobAction(id, action) {
  const job = await json(`/v1/jobs/${id}/${action}`, { method: 'POST' });
  state.jobs.set(id, job);
  renderJobs();
  if (state.selected === id) renderJob(job);
}

async function setPriority(id, value) {
  const priority = Number(value);
  if (!Number.isInteger(priority)) throw new Error('priority: must be a whole number');
  const job = await json(`/v1/jobs/${id}`, { method: 'PATCH', body: { priority } });
  state.jobs.set(id, job);
  renderJobs();
  renderJob(job);
}

async function deleteJob(id) {
  const job = state.jobs.get(id);
  const running = job && !FINISHED.has(job.state);
  const question = running
    ? `Job ${id} is ${job.state}. Stop it and delete it with its tiles and image?`
    : `Delete job ${id} with its tiles and image?`;
  if (!window.confirm(question)) return;
  await call(`/v1/jobs/${id}${running ? '?force=true' : ''}`, { method: 'DELETE' });
  state.jobs.delete(id);
  closeJob();
}

/// Downloads with the bearer header (a plain link could not send it): fetch, then save the blob.
async function download(path, filename) {
  const blob = await (await call(path)).blob();
  const url = URL.createObjectURL(blob);
  const a = el('a', { href: url, download: filename });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

function renderJob(job) {
  if (!$('job-title')) return;
  $('job-title').textContent = `${job.name} (job ${job.id})`;
  const summary = [
    ['State', el('span', { class: `state ${job.state}`, id: 'job-state' }, job.state)],
    ['Progress', el('span', {}, progress(job), ` ${job.tiles_done}/${job.tiles_total} tiles`)],
    ['Priority', String(job.priority)],
    ['Size', `${job.width}×${job.height}${cropText(job.crop)}, tiles of ${job.tile_size}`],
    ['Submitted', `${when(job.submitted_at_ms)}${job.submitter ? ` by ${job.submitter}` : ''}`],
    ['Elapsed', duration(job.elapsed_s)],
    ['ETA', FINISHED.has(job.state) ? '–' : duration(job.eta_s)],
    // sqrt(Σ stderr²) / sqrt(Σ total²) over the tiles done (JobInfo.relative_error).
    ['Noise', job.relative_error == null ? '–'
      : el('span', { id: 'job-noise', title: 'estimated relative RMS error of the tiles done' },
        `${(100 * job.relative_error).toFixed(2)} %`)],
    ['Workers', `${job.workers_live} live, ${job.workers_eligible} eligible`],
  ];
  if (Object.keys(job.requires).length) {
    summary.push(['Requires', Object.entries(job.requires).map(([k, v]) => `${k}=${v}`).join(', ')]);
  }
  $('job-summary').replaceChildren(el('dl', {}, ...summary.flatMap(([k, v]) => [el('dt', {}, k), el('dd', {}, v)])));
  const finished = FINISHED.has(job.state);
  const show = { pause: job.state === 'queued' || job.state === 'running', resume: job.state === 'paused',
    requeue: job.state === 'failed' || job.state === 'cancelled', cancel: !finished, exr: job.state === 'done' };
  for (const [name, visible] of Object.entries(show)) {
    document.querySelector(`#job [data-action="${name}"]`).hidden = !visible;
  }
  const input = $('job-priority-set');
  if (document.activeElement !== input) input.value = job.priority;
  const errors = [];
  if (job.error) errors.push(el('p', { class: 'error' }, job.error));
  if (job.recent_errors.length) {
    errors.push(el('h3', {}, 'Recent tile failures'), el('ul', {}, ...job.recent_errors.map((e) =>
      el('li', {}, `${when(e.at_ms)} tile ${e.tile} on ${e.worker || `worker ${e.worker_id}`}: ${e.message}`))));
  }
  $('job-errors').replaceChildren(...errors);
  renderProvenance(job.provenance);
  $('job-stats').replaceChildren(...Object.entries(job.stats).map(([k, v]) =>
    el('tr', {}, el('th', {}, k.replaceAll('_', ' ')), el('td', { class: 'num' },
      Array.isArray(v) ? v.join(', ') : String(v)))));
}

/// The scene as the workers built it and the single-scattering plan, as text (a worker's
/// report is untrusted: it never becomes markup).
function renderProvenance(p) {
  if (!p) {
    $('job-plan').replaceChildren(el('p', { class: 'muted' }, 'Plan: reported with the first tile.'));
    return;
  }
  const lines = [
    `${p.renderer}: ${p.objects} object(s), ${p.triangles} triangles, ${p.lights} light(s)`,
    ...p.plan.map((line) => `single scattering: ${line}`),
    ...p.warnings.map((line) => `warning: ${line}`),
  ];
  $('job-plan').replaceChildren(el('h3', {}, 'Plan'), el('pre', { id: 'job-plan-text' }, lines.join('\n')));
}

// A cropped job renders only a window of its film (its preview shows the window alone).
function cropText(crop) {
  return crop ? ` (crop ${crop.x},${crop.y} ${crop.width}×${crop.height})` : '';
}

async function loadPreview(id) {
  const blob = await (await call(`/v1/jobs/${id}/image.png`)).blob();
  if (state.selected !== id) return;
  const url = URL.createObjectURL(blob);
  const img = $('preview');
  const old = state.previewUrl;
  state.previewUrl = url;
  img.src = url;
  if (old) img.addEventListener('load', () => URL.revokeObjectURL(old), { once: true });
}

async function loadTiles(id) {
  const map = await json(`/v1/jobs/${id}/tiles`);
  if (state.selected !== id) return;
  state.tiles = map.tiles;
  renderTiles(id);
}

function renderTiles(id) {
  const job = state.jobs.get(id);
  const box = $('tilemap');
  if (!job || !box || !state.tiles) return;
  box.style.aspectRatio = `${job.width} / ${job.height}`;
  const times = state.tileTimes.get(id) || new Map();
  box.replaceChildren(...state.tiles.map((t) => {
    const seen = times.get(t.index);
    const worker = t.worker || (seen && seen.worker);
    const seconds = t.render_seconds ?? (seen && seen.seconds);
    const parts = [`tile ${t.index}: ${t.state}`];
    if (worker) parts.push(`worker ${worker}`);
    if (t.state === 'done' && Number.isFinite(seconds)) parts.push(`rendered in ${seconds.toFixed(2)} s`);
    if (t.failures) parts.push(`${t.failures} failure(s)`);
    const cell = el('div', { class: `tile ${t.state}`, title: parts.join(', '), 'data-tile': t.index });
    cell.style.left = `${(100 * t.rect.x) / job.width}%`;
    cell.style.top = `${(100 * t.rect.y) / job.height}%`;
    cell.style.width = `${(100 * t.rect.width) / job.width}%`;
    cell.style.height = `${(100 * t.rect.height) / job.height}%`;
    return cell;
  }));
}

// ---- workers ---------------------------------------------------------------------------

async function loadWorkers() {
  state.workers = (await json('/v1/workers')).workers;
  renderWorkers();
}

function renderWorkers() {
  const rows = state.workers.map((w) => el('tr', { 'data-worker': w.name },
    el('td', { title: `id ${w.id}, ${w.threads} threads, ${w.version}` }, w.name),
    el('td', { class: `state ${w.state}` }, w.state),
    el('td', {}, w.job != null ? `job ${w.job} tile ${w.tile}` : '–'),
    el('td', {}, ago(w.last_seen_ms)),
    el('td', { class: 'num' }, String(w.tiles_done)),
    el('td', { class: 'num' }, String(w.failures)),
    el('td', { class: 'num' }, w.tiles_per_min.toFixed(1)),
    el('td', {}, w.state === 'idle' || w.state === 'rendering'
      ? el('button', { type: 'button', 'data-action': 'drain', onclick: () => drain(w).catch(notice) }, 'Drain')
      : '')));
  $('workers-table').tBodies[0].replaceChildren(...rows);
  $('workers-empty').hidden = rows.length > 0;
}

async function drain(worker) {
  if (!window.confirm(`Drain worker ${worker.name}? It finishes its tile and exits.`)) return;
  await call(`/v1/workers/${worker.id}/drain`, { method: 'POST' });
  await loadWorkers();
}

// ---- live events -----------------------------------------------------------------------

function setLive(text, ok) {
  const live = $('live');
  live.textContent = text;
  live.classList.toggle('ok', ok);
}

function stopEvents() {
  if (state.stream) state.stream.abort();
  state.stream = null;
}

/// Follows /v1/events; on a dropped stream, reconnects with backoff and refetches the lists
/// once (events may have been missed).
async function followEvents() {
  stopEvents();
  const controller = new AbortController();
  state.stream = controller;
  let backoff = BACKOFF_MIN_MS;
  let first = true;
  while (state.stream === controller) {
    try {
      const headers = { Accept: 'text/event-stream' };
      if (state.lastEventId !== null) headers['Last-Event-ID'] = state.lastEventId;
      const response = await fetch('/v1/events', {
        headers: { ...headers, Authorization: `Bearer ${token()}` },
        signal: controller.signal,
      });
      if (response.status === 401) {
        showLogin(`The coordinator refused the token: ${await errorText(response)}`);
        return;
      }
      if (!response.ok) throw new Error(`events: ${response.status}`);
      setLive('live', true);
      if (!first) await refreshAll();
      first = false;
      backoff = BACKOFF_MIN_MS;
      await readEvents(response, onEvent);
    } catch (e) {
      if (controller.signal.aborted) return;
      if (e instanceof Unauthorized) return;
    }
    if (state.stream !== controller) return;
    first = false;
    setLive('reconnecting', false);
    await new Promise((r) => setTimeout(r, backoff));
    backoff = Math.min(backoff * 2, BACKOFF_MAX_MS);
  }
}

function onEvent(message) {
  if (message.id) state.lastEventId = message.id;
  let event;
  try {
    event = JSON.parse(message.data);
  } catch {
    return;
  }
  switch (event.type) {
    case 'reset':
      refreshAll().catch(notice);
      break;
    case 'job_state':
      loadJob(event.job).catch(notice);
      if (event.job === state.selected) refreshSelected();
      throttled('workers', loadWorkers);
      break;
    case 'tile_done': {
      const times = state.tileTimes.get(event.job) || new Map();
      times.set(event.tile, { worker: event.worker, seconds: event.render_seconds });
      state.tileTimes.set(event.job, times);
      const job = state.jobs.get(event.job);
      if (job && job.tiles_done < job.tiles_total) {
        job.tiles_done += 1;
        renderJobs();
      }
      if (event.job === state.selected) refreshSelected();
      else throttled(`job-${event.job}`, () => loadJob(event.job));
      throttled('workers', loadWorkers);
      break;
    }
    default:
      throttled('workers', loadWorkers);
  }
}

async function refreshAll() {
  await Promise.all([loadJobs(), loadWorkers()]);
  refreshSelected(true);
}

// ---- submit ----------------------------------------------------------------------------

let chosen = [];

function choose(files) {
  chosen = [...files];
  $('chosen').replaceChildren(...chosen.map((f) => el('li', {}, `${f.name} (${f.size} bytes)`)));
  $('submit-button').disabled = !chosen.some((f) => f.name.endsWith('.json'));
  $('submit-message').textContent = '';
}

/// The `obj` mesh paths a scene names.
function meshPaths(scene) {
  const paths = [];
  for (const [i, object] of (scene.objects || []).entries()) {
    const shape = object && object.shape;
    if (shape && shape.type === 'obj') {
      if (typeof shape.path !== 'string') throw new Error(`objects[${i}].shape.path: must be a string`);
      paths.push(shape.path);
    }
  }
  return [...new Set(paths)];
}

async function submitScene() {
  const say = (text) => { $('submit-message').textContent = text; };
  const scenes = chosen.filter((f) => f.name.endsWith('.json'));
  if (scenes.length !== 1) throw new Error(`choose one scene .json (${scenes.length} chosen)`);
  const sceneFile = scenes[0];
  let scene;
  try {
    scene = JSON.parse(await sceneFile.text());
  } catch (e) {
    throw new Error(`${sceneFile.name}: not JSON: ${e.message}`);
  }
  // Meshes by the scene's relative path, matched to the chosen files by name.
  const assets = {};
  const bytesByHash = new Map();
  for (const path of meshPaths(scene)) {
    const base = path.split('/').pop();
    const file = chosen.find((f) => f.name === base);
    if (!file) throw new Error(`${path}: the scene needs this mesh; add ${base} to the chosen files`);
    const bytes = new Uint8Array(await file.arrayBuffer());
    const hash = blake3Hex(bytes);
    assets[path] = hash;
    bytesByHash.set(hash, [path, bytes]);
  }
  if (bytesByHash.size) {
    say('Checking meshes…');
    const { missing } = await json('/v1/assets/missing', {
      method: 'POST', body: { hashes: [...bytesByHash.keys()] },
    });
    for (const hash of missing) {
      const [path, bytes] = bytesByHash.get(hash);
      say(`Uploading ${path} (${bytes.length} bytes)…`);
      await call(`/v1/assets/${hash}`, { method: 'PUT', body: bytes });
    }
  }
  const name = $('job-name').value.trim() || sceneFile.name.replace(/\.json$/, '');
  const job = await json('/v1/jobs', {
    method: 'POST',
    headers: { 'Idempotency-Key': crypto.randomUUID() },
    body: {
      scene, assets, name,
      priority: Number($('job-priority').value) || 0,
      tile_size: Number($('job-tile').value) || 32,
    },
  });
  say(`Submitted job ${job.id} (${job.name}).`);
  state.jobs.set(job.id, job);
  renderJobs();
}

// ---- start -----------------------------------------------------------------------------

function start() {
  $('login').hidden = true;
  $('app').hidden = false;
  $('logout').hidden = false;
  refreshAll().then(followEvents).catch(notice);
}

function wire() {
  $('login-form').addEventListener('submit', (e) => {
    e.preventDefault();
    const value = $('token').value.trim();
    if (!value) return;
    sessionStorage.setItem(TOKEN_KEY, value);
    $('token').value = '';
    start();
  });
  $('logout').addEventListener('click', () => showLogin('Token forgotten.'));
  $('state-filter').addEventListener('change', () => loadJobs().catch(notice));
  $('files').addEventListener('change', (e) => choose(e.target.files));
  const drop = $('drop');
  drop.addEventListener('dragover', (e) => { e.preventDefault(); drop.classList.add('over'); });
  drop.addEventListener('dragleave', () => drop.classList.remove('over'));
  drop.addEventListener('drop', (e) => {
    e.preventDefault();
    drop.classList.remove('over');
    choose(e.dataTransfer.files);
  });
  $('submit-form').addEventListener('submit', (e) => {
    e.preventDefault();
    $('submit-button').disabled = true;
    submitScene().catch((err) => {
      if (!(err instanceof Unauthorized)) $('submit-message').textContent = String(err.message || err);
    }).finally(() => { $('submit-button').disabled = false; });
  });
  // Relative times ("last seen") age between events.
  setInterval(() => { if (!$('app').hidden) renderWorkers(); }, 5000);
}

takeTokenFromFragment();
wire();
// A token given in the fragment of the already open page (a same-document navigation).
window.addEventListener('hashchange', () => {
  if (!new URLSearchParams(location.hash.slice(1)).has('token')) return;
  takeTokenFromFragment();
  if (token()) start();
});
if (token()) start();
else showLogin();
