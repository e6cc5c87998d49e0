// vismap web viewer: connects to vismapd on the page's own host (proto/PROTOCOL.md) and shows the
// live stream in one of two modes:
//   svg      protocol version 1, each frame's SVG put into the page as it comes (version 2 when a
//            lines style is chosen: the server draws the lines into the SVG);
//   bin      protocol version 2, binary triangle lists (proto/FORMAT.md) with their line section,
//            decoded by bin.js and drawn on a 2D canvas: the fills one light tint per mesh (the
//            format has no shading), then the lines as the SVG writer strokes them;
//   compact  protocol version 2, compact frames (proto/COMPACT.md) with raw deflate, decoded by
//            compact.js (decodeCompact, the browser inflates with DecompressionStream) and
//            drawn on a 2D canvas;
//   delta    protocol version 3, delta frames (proto/DELTA.md version 2) with raw deflate,
//            decoded in sequence by delta.js (DeltaDecoder: the page holds the scene, sent once
//            after scene_ready as the sources message (hold_scene), and the previous frame; a
//            frame may be the view's compact frame when that is smaller; a frame that does not
//            apply asks the server for a keyframe), drawn as compact frames are.
// Drag orbits the camera, the wheel zooms. ?scene=NAME opens a library scene, ?format=svg|compact|delta
// picks the mode (the selector switches it live: a new session, the same scene and camera),
// ?viewport=WxH the frame size (default: the view's size). The style controls (?style=fill|lines|
// fill+lines, ?hidden=1, ?crease=DEG; docs/LINES.md) ask the server for line drawings in svg and
// bin modes; they switch live like the format and are off in compact and delta modes, whose
// formats carry no lines.
// Compact and delta frames are decoded in a Worker (decode_worker.js: the frame's bytes go in
// and the draw's buffers come back, transferred, not copied), so the page never waits on a
// decode, and drawn with WebGL 2 (gl_draw.js: one buffer upload, two instanced draws,
// antialiased as the SVG's coverage) where the browser has it on a GPU, else on a 2D canvas
// (drawCompact: a path per colour); ?draw=webgl or ?draw=2d chooses. bin frames are decoded and drawn here on a 2D canvas (their
// lines are strokes, dashed for hidden parts).
// Every frame shown is timed in the page (performance.now()): decode (compact, delta: the
// worker's decode, inflate included; bin: bin.js; svg: the innerHTML assignment, which parses the
// SVG into the DOM) and draw (WebGL: upload and draw calls; canvas: drawCompact; svg: until the
// second animation frame after the insertion, so the paint is in it, and up to one frame interval
// of waiting). With ?timing=1 the draw ends by reading one pixel back (readPixels,
// getImageData), which makes the browser finish rasterizing; without it the draw is the calls
// only. The last 1000 frames' times are in window.vismapViewer.timings ({seq, format, bytes,
// keyframe, triangles, decode_ms, draw_ms, paths_ms: of a 2D draw, building the Path2Ds; the rest
// is the canvas's fill, stroke and raster; worker frames also build_ms (the worker's buffers),
// wait_ms (posting the bytes to having the buffers back, the decode and build in it), upload_ms
// (WebGL: bufferData), script_ms (this thread's time for the frame, without the pixel read back:
// what it costs the page when not timing), renderer: 'webgl2' | '2d'},
// or {seq, format, error} for a frame that did not decode);
// window.vismapViewer.camera(fields) sends a camera with these fields (a bench drives the
// viewer with it: bench/stream/clients.py) and returns its seq.
(() => {
  const view = document.getElementById('view');
  const stats = document.getElementById('stats');
  const formatSelect = document.getElementById('format');
  const params = new URLSearchParams(location.search);
  const FORMATS = ['svg', 'bin', 'compact', 'delta'];
  let format = FORMATS.includes(params.get('format')) ? params.get('format') : 'svg';
  formatSelect.value = format;
  const styleSelect = document.getElementById('style');
  const hiddenBox = document.getElementById('hidden');
  const creaseInput = document.getElementById('crease');
  if (['fill', 'lines', 'fill+lines'].includes(params.get('style'))) styleSelect.value = params.get('style');
  hiddenBox.checked = params.get('hidden') === '1';
  if (params.get('crease') !== null) creaseInput.value = params.get('crease');
  const linesAllowed = () => format === 'svg' || format === 'bin';
  const style = () => (linesAllowed() ? styleSelect.value : 'fill');
  let ws = null, pendingHeader = null, orbit = null, keepOrbit = false;
  let seq = 0, sentAt = new Map(), lastFps = [];
  let lastScene = null;  // {message, bytes}: sent again when the mode changes
  let bin = null;  // bin.js (decodeBin), imported on first use
  let meshEdges = null;  // mesh_edges.js (sharedEdges), imported before the first 2D canvas draw
  let pendingSources = false;  // the next binary message is the held scene's sources
  // WebGL 2 where the browser has it on a GPU (a probe canvas says); a software rasterizer
  // (SwiftShader, llvmpipe) draws a 1920x1080 bunny frame in ~3 s where the 2D canvas takes
  // ~0.1 s (docs/STREAMING.md), so there the 2D canvas; ?draw=webgl or ?draw=2d decides.
  const useGl = (() => {
    if (params.get('draw') === '2d') return false;
    const gl = document.createElement('canvas').getContext('webgl2');
    if (!gl) return false;
    if (params.get('draw') === 'webgl') return true;
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
    return !/swiftshader|llvmpipe|software/i.test(name);
  })();
  let glModule = null, glDraw = null;  // gl_draw.js, and the canvas's GlDraw (null: 2D canvas)
  // The decoding worker: requests by id, answered in order of completion.
  const worker = new Worker('decode_worker.js', { type: 'module' });
  const replies = new Map();
  let requestId = 0;
  worker.onmessage = (e) => { const r = replies.get(e.data.id); replies.delete(e.data.id); if (r) r(e.data); };
  const inWorker = (kind, bytes) => new Promise((resolve) => {
    const id = ++requestId;
    replies.set(id, resolve);
    worker.postMessage({ id, kind, bytes, target: useGl ? 'gl' : '2d' },
      bytes ? [bytes] : []);
  });
  let frameNo = 0, shownNo = 0;  // a decode that ends after a newer frame's is not drawn
  const timingFinish = params.get('timing') === '1';
  const vp = /^(\d+)x(\d+)$/.exec(params.get('viewport') || '');
  const timings = [];
  let pathsMs = null;  // of the last drawCompact: building the paths (the rest is canvas work)
  const record = (h, triangles, decodeMs, drawMs, paths = null) => {
    timings.push({ seq: h.seq, format: h.format, bytes: h.bytes, keyframe: !!h.keyframe, triangles,
                   decode_ms: decodeMs, draw_ms: drawMs, paths_ms: paths });
    if (timings.length > 1000) timings.shift();
  };
  const afterPaint = () => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
  const send = (m) => ws && ws.readyState === 1 && ws.send(JSON.stringify(m));

  function connect() {
    if (ws) { ws.onclose = null; ws.close(); }
    pendingHeader = null;
    pendingSources = false;
    worker.postMessage({ kind: 'reset' });  // a new session starts from a keyframe
    ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/');
    ws.binaryType = 'arraybuffer';
    ws.onopen = () => {
      const viewport = vp ? { width: +vp[1], height: +vp[2] }
        : { width: view.clientWidth | 0 || 800, height: view.clientHeight | 0 || 600 };
      const lines = style() !== 'fill';
      const hello = { type: 'hello', version: format === 'delta' ? 3 : format === 'svg' && !lines ? 1 : 2, format, viewport };
      if (format === 'compact' || format === 'delta') hello.compression = 'deflate';  // browsers inflate it natively
      if (format === 'delta') hello.hold_scene = true;  // the scene's sources once, then frames without
      if (lines) {
        hello.style = style();
        hello.hidden = hiddenBox.checked;
        const a = Number(creaseInput.value);
        if (creaseInput.value !== '' && Number.isFinite(a)) hello.crease_angle = Math.min(180, Math.max(0, a));
      }
      if (params.get('token')) hello.token = params.get('token');
      send(hello);
    };
    ws.onclose = (e) => { stats.textContent = `closed ${e.code} ${e.reason}`; };
    ws.onmessage = onMessage;
  }
  setInterval(() => send({ type: 'ping' }), 20000);  // keeps the idle timeout away

  function onMessage(e) {
    if (pendingSources) {  // the held scene (the worker's decoder takes it before the frames)
      pendingSources = false;
      inWorker('sources', e.data).then((r) => { if (!r.ok) stats.textContent = `sources: ${r.error}`; });
      return;
    }
    if (pendingHeader) {  // the payload that follows a frame header
      const h = pendingHeader; pendingHeader = null;
      if (h.format === 'compact' || h.format === 'delta') return showDecoded(h, e.data);
      if (h.format === 'bin') return showBin(h, e.data);
      return showSvg(h, e.data);
    }
    const m = JSON.parse(e.data);
    if (m.type === 'welcome') {
      stats.textContent = `session ${m.session}`;
      if (lastScene) {
        send(lastScene.message);
        if (lastScene.bytes) ws.send(lastScene.bytes);
      } else if (params.get('scene')) {
        loadScene({ type: 'scene', library: params.get('scene') });
      }
    } else if (m.type === 'scene_ready') {
      if (!(keepOrbit && orbit)) {
        const c = m.camera, d = c.eye.map((v, i) => v - c.target[i]);
        const r = Math.hypot(...d);
        orbit = { target: c.target, r, yaw: Math.atan2(d[0], d[2]), pitch: Math.asin(d[1] / r) };
      }
      keepOrbit = false;
      stats.textContent = `${m.name}: ${m.triangles} triangles`;
      sendCamera();
    } else if (m.type === 'frame') {
      pendingHeader = m;
    } else if (m.type === 'sources') {
      pendingSources = true;
    } else if (m.type === 'error') {
      stats.textContent = `error ${m.code}: ${m.message}`;
    }
  }

  function shown(h) {
    const t = sentAt.get(h.seq); sentAt.delete(h.seq);
    const now = performance.now();
    lastFps.push(now); while (lastFps.length && now - lastFps[0] > 1000) lastFps.shift();
    const count = h.format === 'compact' ? `${h.out_triangles} triangles`
      : h.format === 'delta' ? `${h.whole} whole + ${h.polygons} polygons${h.keyframe ? ' (keyframe)' : ''}`
      : `${h.fragments} fragments` + (h.line_chains !== undefined ? `  ${h.line_chains} chains` : '');
    stats.textContent = `${lastFps.length} fps  render ${h.render_ms.toFixed(1)} ms  ` +
      (t ? `latency ${(now - t).toFixed(0)} ms  ` : '') + `${(h.bytes / 1024).toFixed(0)} KiB  ${count}`;
  }

  async function showSvg(h, text) {
    const no = ++frameNo;
    const t0 = performance.now();
    view.innerHTML = text;
    const t1 = performance.now();
    shownNo = no;
    shown(h);
    await afterPaint();
    record(h, null, t1 - t0, performance.now() - t1);
  }

  // The canvas, with the context kind the frame needs (a canvas keeps its first kind).
  function canvasFor(kind) {
    let canvas = view.querySelector('canvas');
    if (!canvas || canvas.dataset.context !== kind) {
      view.innerHTML = '';
      canvas = document.createElement('canvas');
      canvas.dataset.context = kind;
      view.appendChild(canvas);
      glDraw = null;
    }
    return canvas;
  }

  // A compact or delta frame: decoded (and made ready to draw) in the worker, then drawn with
  // WebGL 2 or the 2D canvas, each drawn when it is the newest (delta frames decode in order).
  async function showDecoded(h, bytes) {
    const no = ++frameNo;
    const t0 = performance.now();
    const r = await inWorker(h.format, bytes);
    const t1 = performance.now();
    if (!r.ok) {
      timings.push({ seq: h.seq, format: h.format, error: r.error });
      if (r.outOfSync) {
        send({ type: 'keyframe' });  // this frame did not apply: the next one stands alone
        sendCamera();
        return;
      }
      stats.textContent = `${h.format} frame: ${r.error}`;
      return;
    }
    if (no < shownNo) return;
    shownNo = no;
    const f = r.frame;
    let times;
    if (f.gl) {
      if (!glDraw) {
        if (!glModule) glModule = await import('./gl_draw.js');
        glDraw = glModule.GlDraw.create(canvasFor('webgl2'));
      }
      if (glDraw) {
        times = glDraw.draw(f.gl, f.width, f.height, timingFinish);
        glDraw.gl.canvas.dataset.frames = String(shownNo);
      }
    }
    if (!times) {  // no WebGL 2 (or ?draw=2d): the 2D canvas, with the frame's arrays
      if (!meshEdges) meshEdges = await import('./mesh_edges.js');
      const s0 = performance.now();
      drawCompact(f, f.colors);
      const s1 = performance.now();
      if (timingFinish) view.querySelector('canvas').getContext('2d').getImageData(0, 0, 1, 1);
      times = { uploadMs: null, callsMs: s1 - s0, finishMs: performance.now() - s1 };
    }
    const t2 = performance.now();
    timings.push({ seq: h.seq, format: h.format, bytes: h.bytes, keyframe: f.keyframe, triangles: f.triangles,
                   decode_ms: r.decodeMs, build_ms: r.buildMs, wait_ms: t1 - t0, upload_ms: times.uploadMs,
                   draw_ms: times.callsMs + times.finishMs, script_ms: t2 - t1 - times.finishMs,
                   paths_ms: f.gl ? null : pathsMs, renderer: f.gl ? 'webgl2' : '2d' });
    if (timings.length > 1000) timings.shift();
    shown(h);
  }

  // A bin frame: the triangles welded where their corners are bit-identical (the map's neighbours
  // share float32 vertices, FORMAT.md), so that drawCompact strokes the shared edges and no seam
  // shows inside a fill; one light tint per mesh; then the lines over them.
  async function showBin(h, bytes) {
    const no = ++frameNo;
    try {
      if (!bin) bin = await import('./bin.js');
      if (!meshEdges) meshEdges = await import('./mesh_edges.js');
      const t0 = performance.now();
      const f = bin.decodeBin(bytes);
      const t1 = performance.now();
      shownNo = no;
      const w = weld(f.positions);
      const colors = new Uint8Array(3 * f.triangles);
      for (let t = 0; t < f.triangles; ++t) colors.set(meshTint(f.mesh[t]), 3 * t);
      drawCompact({ width: f.width, height: f.height, quantum: 1, xy: w.xy, indices: w.indices }, colors);
      const canvas = view.querySelector('canvas');
      drawLines(canvas.getContext('2d'), f.lines);
      canvas.dataset.chains = String(f.lines ? f.lines.chainEnd.length : 0);
      canvas.dataset.triangles = String(f.triangles);
      if (timingFinish) canvas.getContext('2d').getImageData(0, 0, 1, 1);
      record(h, f.triangles, t1 - t0, performance.now() - t1, pathsMs);
      shown(h);
    } catch (err) {
      timings.push({ seq: h.seq, format: h.format, error: String(err.message || err) });
      stats.textContent = `${err.message || err}`;
    }
  }

  // A light tint per mesh (sRGB bytes), far enough from white that the page's object/background
  // test and the eye tell it from the background, light enough that every line kind shows on it.
  const tints = new Map();
  function meshTint(m) {
    let c = tints.get(m);
    if (!c) {
      const hue = (m * 137.508) % 360, s = 0.35, l = 0.84;  // golden-angle hues, HSL to RGB
      const k = (n) => (n + hue / 30) % 12, a = s * Math.min(l, 1 - l);
      const f = (n) => Math.round(255 * (l - a * Math.max(-1, Math.min(k(n) - 3, 9 - k(n), 1))));
      c = [f(0), f(8), f(4)];
      tints.set(m, c);
    }
    return c;
  }

  // Corners (6 floats per triangle) to vertices: equal bit patterns of (x, y) become one vertex
  // (open addressing over the float32 bits; a Map of string keys is several times slower).
  function weld(pos) {
    const n = pos.length / 2, bits = new Uint32Array(pos.buffer, pos.byteOffset, pos.length);
    let size = 1; while (size < 2 * n) size <<= 1;
    const slot = new Int32Array(size).fill(-1), xy = new Float32Array(pos.length);
    const xyb = new Uint32Array(xy.buffer), indices = new Uint32Array(n);
    let nv = 0;
    for (let i = 0; i < n; ++i) {
      const bx = bits[2 * i], by = bits[2 * i + 1];
      let hsh = (Math.imul(bx, 0x9e3779b1) ^ Math.imul(by, 0x85ebca77)) & (size - 1);
      for (;;) {
        const v = slot[hsh];
        if (v < 0) {
          slot[hsh] = nv; xy[2 * nv] = pos[2 * i]; xy[2 * nv + 1] = pos[2 * i + 1]; indices[i] = nv++;
          break;
        }
        if (xyb[2 * v] === bx && xyb[2 * v + 1] === by) { indices[i] = v; break; }
        hsh = (hsh + 1) & (size - 1);
      }
    }
    return { xy: xy.subarray(0, 2 * nv), indices };
  }

  // The line section as the SVG writer draws it (core/write/svg.cpp write_lines): 1 px round
  // strokes, the hidden parts first, dashed 4 3, then the visible ones kind by kind, in the
  // writer's default colours.
  const LINE_COLORS = ['#000000', '#000000', '#404040', '#b00000', '#000000'];
  function drawLines(ctx, lines) {
    if (!lines) return;
    const { chainEnd, chainInfo, points } = lines;
    ctx.lineWidth = 1;
    ctx.lineCap = 'round';
    ctx.lineJoin = 'round';
    for (const hidden of [1, 0]) {
      ctx.setLineDash(hidden ? [4, 3] : []);
      for (let kind = 0; kind < LINE_COLORS.length; ++kind) {
        const p = new Path2D();
        let any = false;
        for (let c = 0, start = 0; c < chainEnd.length; start = chainEnd[c++]) {
          const w = chainInfo[c];
          if ((w & 255) !== kind || ((w >> 9) & 1) !== hidden) continue;
          any = true;
          p.moveTo(points[2 * start], points[2 * start + 1]);
          if (chainEnd[c] - start === 1) p.lineTo(points[2 * start], points[2 * start + 1]);  // a dot
          for (let i = start + 1; i < chainEnd[c]; ++i) p.lineTo(points[2 * i], points[2 * i + 1]);
          if ((w >> 8) & 1) p.closePath();
        }
        if (!any) continue;
        ctx.strokeStyle = LINE_COLORS[kind];
        ctx.stroke(p);
      }
    }
    ctx.setLineDash([]);
  }

  // One path per colour (compact.js's triangleColors: the SVG writer's sRGB of mesh colour x
  // shade, or the id colour without shades): a path's fill has no seams inside, and the edges
  // that two triangles share are stroked 1 px in the fill colour, as the SVG writer does, so
  // background does not show through where abutting fills of different colours each cover part
  // of a pixel. Silhouette edges are not stroked (outlines are not fattened). The strokes are all
  // drawn first and the fills over them, so a stroke shows only where the fills leave a pixel
  // partly uncovered: stroked after its fill, group by group, the 1 px stroke of a sub-pixel
  // sliver (dark, at a grazing angle, along a fold of the armadillo) stayed on top of its
  // neighbours as a dark line the SVG does not show (bench/stream/clients.py's screenshots of
  // cornell_armadillo; delta against svg 0.37% of object pixels differ, 0.30% now). An edge is shared
  // when it is used twice or more, in either direction: counted on each vertex's list of
  // corners that follow it (typed arrays, prefix sums; a Map of edges took ~60% of the draw's
  // script time for a 1920x1080 bunny frame, bench/stream/clients.py).
  function drawCompact(f, colors) {
    const t0 = performance.now();
    const canvas = canvasFor('2d');
    if (canvas.width !== f.width || canvas.height !== f.height) { canvas.width = f.width; canvas.height = f.height; }
    const ctx = canvas.getContext('2d');
    ctx.clearRect(0, 0, f.width, f.height);
    const q = f.quantum, xy = f.xy, ix = f.indices, n = ix.length / 3;
    const shared = meshEdges.sharedEdges(ix, xy.length / 2);  // loaded before any 2D draw
    // colors: 3 sRGB bytes per triangle
    const groups = new Map();  // packed colour -> {fill: Path2D, stroke: Path2D, style}
    let g = -1, p = null;
    for (let t = 0; t < n; ++t) {
      const c = (colors[3 * t] << 16) | (colors[3 * t + 1] << 8) | colors[3 * t + 2];
      if (c !== g) {
        g = c;
        p = groups.get(c);
        if (!p) {
          const style = `rgb(${colors[3 * t]},${colors[3 * t + 1]},${colors[3 * t + 2]})`;
          p = { fill: new Path2D(), stroke: new Path2D(), style };
          groups.set(c, p);
        }
      }
      const v0 = ix[3 * t], v1 = ix[3 * t + 1], v2 = ix[3 * t + 2];
      const x0 = xy[2 * v0] / q, y0 = xy[2 * v0 + 1] / q, x1 = xy[2 * v1] / q, y1 = xy[2 * v1 + 1] / q;
      const x2 = xy[2 * v2] / q, y2 = xy[2 * v2 + 1] / q;
      p.fill.moveTo(x0, y0);
      p.fill.lineTo(x1, y1);
      p.fill.lineTo(x2, y2);
      p.fill.closePath();
      if (shared[t] & 1) { p.stroke.moveTo(x0, y0); p.stroke.lineTo(x1, y1); }
      if (shared[t] & 2) { p.stroke.moveTo(x1, y1); p.stroke.lineTo(x2, y2); }
      if (shared[t] & 4) { p.stroke.moveTo(x2, y2); p.stroke.lineTo(x0, y0); }
    }
    pathsMs = performance.now() - t0;
    ctx.lineWidth = 1;
    ctx.lineJoin = 'bevel';
    for (const p of groups.values()) {  // every stroke under every fill: see above
      ctx.strokeStyle = p.style;
      ctx.stroke(p.stroke);
    }
    for (const p of groups.values()) {
      ctx.fillStyle = p.style;
      ctx.fill(p.fill);
    }
    canvas.dataset.frames = String(shownNo);  // for tests: frames drawn so far
  }

  function sendCamera() {
    if (!orbit) return;
    const { target: t, r, yaw, pitch } = orbit;
    const eye = [t[0] + r * Math.cos(pitch) * Math.sin(yaw), t[1] + r * Math.sin(pitch),
                 t[2] + r * Math.cos(pitch) * Math.cos(yaw)];
    sentAt.set(++seq, performance.now());
    if (sentAt.size > 100) sentAt.delete(sentAt.keys().next().value);
    send({ type: 'camera', seq, eye, target: t });  // the server renders only the latest
  }

  window.vismapViewer = {
    timings,
    camera(fields) {
      sentAt.set(++seq, performance.now());
      send(Object.assign({}, fields, { type: 'camera', seq }));
      return seq;
    },
  };

  function loadScene(message, bytes) {
    lastScene = { message, bytes };
    send(message);
    if (bytes) ws.send(bytes);  // the scene's bytes as one binary message
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

  const styleControls = () => {
    for (const el of [styleSelect, hiddenBox, creaseInput]) el.disabled = !linesAllowed();
  };
  styleControls();
  const reconnect = () => {
    keepOrbit = true;  // the new session shows the same scene from the same camera
    connect();
  };
  formatSelect.onchange = () => { format = formatSelect.value; styleControls(); reconnect(); };
  styleSelect.onchange = reconnect;
  hiddenBox.onchange = reconnect;
  creaseInput.onchange = reconnect;
  document.getElementById('load').onclick = () => {
    const n = document.getElementById('name').value.trim();
    if (n) loadScene({ type: 'scene', library: n });
  };
  document.getElementById('file').onchange = async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    const bytes = await f.arrayBuffer();
    loadScene({ type: 'scene', name: f.name, size: bytes.byteLength }, bytes);
  };
  document.getElementById('scene').style.display = 'none';
  connect();
})();
