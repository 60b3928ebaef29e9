// The stats overlay text and the connection banner.

function fixed(v, digits) {
  return Number.isFinite(v) ? v.toFixed(digits) : '—';
}

// Overlay text for a stats snapshot (see App.snapshot()).
export function statsText(s) {
  const lines = [
    `render   ${fixed(s.renderFps, 1)} fps`,
    `frames   ${fixed(s.framesPerSec, 1)} /s   seq ${s.seq ?? '—'}`,
    `stream   ${fixed(s.kbitPerSec, 0)} kbit/s   ${fixed(s.bytesPerVertex, 2)} B/vertex`,
    `latency  ${fixed(s.latencyMs, 1)} ms`,
    `decode   ${fixed(s.decodeMs, 2)} ms + ${fixed(s.prepareMs, 2)} ms smooth   upload ${fixed(s.uploadMs, 2)} ms`,
    `server   ${fixed(s.serverStepsPerSec, 1)} steps/s   step ${fixed(s.serverStepMs, 2)} ms   clients ${s.clients ?? '—'}`,
    `hair     ${s.guides} guides × ${s.verts} → ${s.renderStrands} strands`,
    `webgl    ${s.renderer.length > 44 ? `${s.renderer.slice(0, 43)}…` : s.renderer}${s.antialias ? '' : ' (no MSAA)'}`,
  ];
  if (s.paused) lines.push('paused');
  return lines.join('\n');
}

export class Banner {
  constructor(elem) { this.el = elem; }

  show(text, isError) {
    this.el.textContent = text;
    this.el.classList.toggle('error', !!isError);
    this.el.classList.remove('hidden');
  }

  hide() { this.el.classList.add('hidden'); }
}
