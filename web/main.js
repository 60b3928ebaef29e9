// Entry point: starts the viewer, or says clearly why it cannot run.
import { App } from './app.js';

function fail(message) {
  const banner = document.getElementById('banner');
  banner.textContent = message;
  banner.classList.remove('hidden');
  banner.classList.add('error');
}

try {
  // ?ws=URL points the page at another strandcastd (the page is normally served by it)
  const url = new URLSearchParams(location.search).get('ws') || undefined;
  const app = new App({
    canvas: document.getElementById('view'),
    panelEl: document.getElementById('panel'),
    statsEl: document.getElementById('stats'),
    bannerEl: document.getElementById('banner'),
    url,
  });
  window.strandcast = app;
  app.start();
} catch (e) {
  fail(e.message);
  throw e;
}
