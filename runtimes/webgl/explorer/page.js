// The page's state: the material, the controls' values (ui), the status the tests read, and errors shown in one line.

export const $ = (id) => document.getElementById(id);
export const query = new URLSearchParams(location.search);
export const DEG = Math.PI / 180;
export const pageStart = performance.now();
export const status = { ready: false, errors: [], drawn: {}, ms: {} };
export let material = null;
export function setMaterial(m) { material = m; }
export const ui = {};   // the controls' current values (readControls)

export function writeStatus() { $('status-json').textContent = JSON.stringify(status); }

// One line of error on the page; the first error stays (the page stops drawing on a failed load).
export function showError(err) {
  const msg = String((err && err.message) || err || 'unknown error').split('\n')[0];
  status.errors.push(msg);
  const el = $('error');
  if (!el.classList.contains('shown')) { el.textContent = msg; el.title = msg; el.classList.add('shown'); }
  writeStatus();
}
window.addEventListener('error', (e) => showError(e.error || e.message));
window.addEventListener('unhandledrejection', (e) => showError(e.reason));

export function maybeReady() {
  if (status.ready || !['sphere', 'polar', 'slice', 'albedo'].every((k) => status.drawn[k])) return writeStatus();
  status.ready = true;
  document.body.dataset.ready = '1';
  writeStatus();
}
