// Entry point: starts the viewer, or says clearly why it cannot run.
import { App } from './app.js';

function fail(message) {
  const banner = document.getElementById('banner');
  banner.textContent = message;
  banner.classList.remove('hidden');
  banner.classList.add('error');
}

try {
  // ?ws=URL points the page at another strandcastd (the page is normally served by it);
  // ?aa=0 or ?aa=1 turns multisampling off or on (default: on, except on CPU rasterizers)
  const query = new URLSearchParams(location.search);
  const url = query.get('ws') || undefined;
  const antialias = query.has('aa') ? query.get('aa') !== '0' : undefined;
  const app = new App({
    canvas: document.getElementById('view'),
    panelEl: document.getElementById('panel'),
    statsEl: document.getElementById('stats'),
    bannerEl: document.getElementById('banner'),
    url,
    antialias,
  });
  window.strandcast = app;
  app.start();
} catch (e) {
  fail(e.message);
  throw e;
}
