// vismap web viewer: connects to vismapd on the page's own host (proto/PROTOCOL.md), shows the
// live SVG stream and orbits the camera with the mouse (drag: orbit, wheel: zoom).
(() => {
  const view = document.getElementById('view');
  const stats = document.getElementById('stats');
  const params = new URLSearchParams(location.search);
  const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/');
  let pendingHeader = null, orbit = null, seq = 0, sentAt = new Map(), lastFps = [];
  const send = (m) => ws.readyState === 1 && ws.send(JSON.stringify(m));

  ws.onopen = () => {
    const hello = { type: 'hello', version: 1, format: 'svg',
                    viewport: { width: view.clientWidth | 0 || 800, height: view.clientHeight | 0 || 600 } };
    if (params.get('token')) hello.token = params.get('token');
    send(hello);
    setInterval(() => send({ type: 'ping' }), 20000);  // keeps the idle timeout away
  };
  ws.onclose = (e) => { stats.textContent = `closed ${e.code} ${e.reason}`; };
  ws.onmessage = (e) => {
    if (pendingHeader) {  // the payload that follows a frame header
      view.innerHTML = e.data;
      const h = pendingHeader; pendingHeader = null;
      const t = sentAt.get(h.seq); sentAt.delete(h.seq);
      const now = performance.now();
      lastFps.push(now); while (lastFps.length && now - lastFps[0] > 1000) lastFps.shift();
      stats.textContent = `${lastFps.length} fps  render ${h.render_ms.toFixed(1)} ms  ` +
        (t ? `latency ${(now - t).toFixed(0)} ms  ` : '') + `${(h.bytes / 1024).toFixed(0)} KiB  ${h.fragments} fragments`;
      return;
    }
    const m = JSON.parse(e.data);
    if (m.type === 'welcome') {
      stats.textContent = `session ${m.session}`;
      const lib = params.get('scene');
      if (lib) send({ type: 'scene', library: lib });
    } else if (m.type === 'scene_ready') {
      const c = m.camera, d = c.eye.map((v, i) => v - c.target[i]);
      const r = Math.hypot(...d);
      orbit = { target: c.target, r, yaw: Math.atan2(d[0], d[2]), pitch: Math.asin(d[1] / r) };
      stats.textContent = `${m.name}: ${m.triangles} triangles`;
      sendCamera();
    } else if (m.type === 'frame') {
      pendingHeader = m;
    } else if (m.type === 'error') {
      stats.textContent = `error ${m.code}: ${m.message}`;
    }
  };

  function sendCamera() {
    if (!orbit) return;
    const { target: t, r, yaw, pitch } = orbit;
    const eye = [t[0] + r * Math.cos(pitch) * Math.sin(yaw), t[1] + r * Math.sin(pitch),
                 t[2] + r * Math.cos(pitch) * Math.cos(yaw)];
    sentAt.set(++seq, performance.now());
    if (sentAt.size > 100) sentAt.delete(sentAt.keys().next().value);
    send({ type: 'camera', seq, eye, target: t });  // the server renders only the latest
  }

  let drag = null;
  view.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; view.setPointerCapture(e.pointerId); });
  view.addEventListener('pointerup', () => { drag = null; });
  view.addEventListener('pointermove', (e) => {
    if (!drag || !orbit) return;
    orbit.yaw -= (e.clientX - drag[0]) * 0.01;
    orbit.pitch = Math.max(-1.5, Math.min(1.5, orbit.pitch + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    sendCamera();
  });
  view.addEventListener('wheel', (e) => {
    if (!orbit) return;
    e.preventDefault();
    orbit.r *= Math.exp(e.deltaY * 0.001);
    sendCamera();
  }, { passive: false });

  document.getElementById('load').onclick = () => {
    const n = document.getElementById('name').value.trim();
    if (n) send({ type: 'scene', library: n });
  };
  document.getElementById('file').onchange = async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    const bytes = await f.arrayBuffer();
    send({ type: 'scene', name: f.name, size: bytes.byteLength });
    ws.send(bytes);  // the scene's bytes as one binary message
  };
  document.getElementById('scene').style.display = 'none';
})();
