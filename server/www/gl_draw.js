// WebGL 2 drawing of a decoded frame's triangles (server/www/viewer.js): one buffer upload a
// frame, made by the decoding worker (decode_worker.js glInstances), and two instanced draws
// from it: the strokes of the shared edges, then the fills over them.
//
// Antialiasing as the SVG's: the SVG writer fills each triangle with coverage antialiasing and
// strokes the edges it shares 1 px wide in its own colour (hiding the seams where two fills of
// partial coverage meet); the 2D canvas draws every stroke first and the fills over them, which
// matches the SVG to 0.03% of the bunny's object pixels. The same here: each instance is grown
// to cover every pixel it touches, and the fragment shader counts the pixel's 4x4 samples inside
// the stroke's rectangle or the triangle (coverage), drawn over what is there in premultiplied
// colour. Drawn with exact coverage and no strokes instead (a partition of the pixels), 1.3% of
// the bunny's object pixels differed from the SVG by more than the viewer test's 48/255: the
// strokes widen the sub-pixel slivers along silhouettes (grazing, dark) into the 1 px dark rim
// that the SVG shows.
//
// A sample inside a triangle: tested against the triangle's own corners (exact in float32) with
// each edge evaluated in one canonical direction (from its lexicographically smaller end), so
// the two triangles on an edge compute the same number and take opposite sides of it, and a
// sample on the edge goes to the side the canonical direction keeps. (Distances interpolated
// from the corners were not exact: 1.3% of the bunny's pixels had a sample counted twice, or by
// neither.) Samples are off the 1/8 px lattice: the frame's corners are on a 1/16 px grid.
const COMMON = `#version 300 es
precision highp float;
uniform vec2 size;
vec4 clip(vec2 p) { return vec4(p.x / size.x * 2.0 - 1.0, 1.0 - p.y / size.y * 2.0, 0.0, 1.0); }
`;
const SAMPLES = `${COMMON}
vec2 sample_at(int i, int j) {  // pixels, y down
  vec2 p = vec2(gl_FragCoord.x, size.y - gl_FragCoord.y);
  return p + (vec2(float(i), float(j)) + 0.5) * 0.25 - 0.5 + vec2(0.0317, 0.0213);
}
`;
// A triangle (instance: its corners c0, c1, c2), grown by 1 px across each edge (a corner at
// most 64 px: a sliver's sharp corner spikes).
const FILL_VERTEX = `${COMMON}
in vec2 c0;
in vec2 c1;
in vec2 c2;
in vec4 color;
flat out vec2 v0;
flat out vec2 v1;
flat out vec2 v2;
flat out vec4 vColor;
vec2 inward(vec2 a, vec2 b) { vec2 e = normalize(b - a); return vec2(-e.y, e.x); }
void main() {
  v0 = c0; v1 = c1; v2 = c2; vColor = color;
  vec2 c[3] = vec2[3](c0, c1, c2);
  int j = gl_VertexID;
  vec2 p = c[j], prev = c[(j + 2) % 3], next = c[(j + 1) % 3];
  vec2 na = inward(prev, p), nb = inward(p, next);
  // the corner of the lines n.x = n.p - 1 through the two edges at p, moved out by 1 px
  float det = na.x * nb.y - na.y * nb.x;
  vec2 g = p;
  if (abs(det) > 1e-9) {
    float ca = dot(na, p) - 1.0, cb = dot(nb, p) - 1.0;
    g = vec2(ca * nb.y - cb * na.y, na.x * cb - nb.x * ca) / det;
    float d = length(g - p);
    if (d > 64.0) g = p + (g - p) * (64.0 / d);
  }
  gl_Position = clip(g);
}`;
const FILL_FRAGMENT = `${SAMPLES}
flat in vec2 v0;
flat in vec2 v1;
flat in vec2 v2;
flat in vec4 vColor;
out vec4 outColor;
float side(vec2 a, vec2 b, vec2 s) { return (b.x - a.x) * (s.y - a.y) - (b.y - a.y) * (s.x - a.x); }
bool before(vec2 a, vec2 b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }
// s is on the inner side of edge a -> b (the triangles are positive, y down), or on the edge and
// a -> b is the canonical direction.
bool inside(vec2 a, vec2 b, vec2 s) {
  bool fwd = before(a, b);
  float e = fwd ? side(a, b, s) : -side(b, a, s);
  return e > 0.0 || (e == 0.0 && fwd);
}
bool in_triangle(vec2 s) { return inside(v0, v1, s) && inside(v1, v2, s) && inside(v2, v0, s); }
void main() {
  // The four outermost samples inside: all sixteen are (the triangle is convex), as counted.
  if (in_triangle(sample_at(0, 0)) && in_triangle(sample_at(3, 0)) && in_triangle(sample_at(0, 3)) &&
      in_triangle(sample_at(3, 3))) {
    outColor = vColor;
    return;
  }
  float n = 0.0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) n += in_triangle(sample_at(i, j)) ? 1.0 : 0.0;
  }
  if (n == 0.0) discard;
  float c = n / 16.0;
  outColor = vec4(vColor.rgb * c, c);
}`;
// A stroke (instance: the edge a -> b): the band 1 px wide along it, butt ends (as the 2D
// canvas's and the SVG's strokes of separate segments), drawn over the pixels it touches.
const STROKE_VERTEX = `${COMMON}
in vec2 a;
in vec2 b;
in vec4 color;
flat out vec2 va;
flat out vec2 vb;
flat out vec4 vColor;
void main() {
  va = a; vb = b; vColor = color;
  vec2 u = b - a;
  u = length(u) > 0.0 ? normalize(u) : vec2(1.0, 0.0);
  vec2 n = vec2(-u.y, u.x);
  int k = gl_VertexID;  // two triangles: (0, 1, 2), (2, 1, 3) of the corners below
  int q = k < 3 ? k : k == 3 ? 2 : k == 4 ? 1 : 3;
  vec2 p = (q == 0 || q == 2 ? a - 0.75 * u : b + 0.75 * u) + (q < 2 ? -1.25 : 1.25) * n;
  gl_Position = clip(p);
}`;
const STROKE_FRAGMENT = `${SAMPLES}
flat in vec2 va;
flat in vec2 vb;
flat in vec4 vColor;
out vec4 outColor;
// Its coverage in closed form: a box filter across the band 1 px wide (1 - |h|) and across each
// butt end (0.5 + the distance past it), where the SVG's and the 2D canvas's come from samples;
// a stroke lies under the fills, so only its part outside them shows, and that is within a
// grid step of the straight line.
void main() {
  vec2 e = vb - va;
  float len = length(e);
  if (len == 0.0) discard;
  vec2 u = e / len;
  vec2 d = vec2(gl_FragCoord.x, size.y - gl_FragCoord.y) - va;
  float t = dot(d, u), h = d.x * u.y - d.y * u.x;
  float c = clamp(1.0 - abs(h), 0.0, 1.0) * clamp(0.5 + t, 0.0, 1.0) * clamp(0.5 + len - t, 0.0, 1.0);
  if (c <= 0.0) discard;
  outColor = vec4(vColor.rgb * c, c);
}`;
const STROKE_BYTES = 20; // decode_worker.js: ax, ay, bx, by (float32), r, g, b, a (uint8)
const FILL_BYTES = 28; // x0, y0, x1, y1, x2, y2 (float32), r, g, b, a (uint8)

export class GlDraw {
  // A WebGL 2 context on the canvas, or null when the browser has none (then: the 2D canvas).
  static create(canvas) {
    const gl = canvas.getContext('webgl2', {
      antialias: false, premultipliedAlpha: true, alpha: true, preserveDrawingBuffer: true,
    });
    return gl ? new GlDraw(gl) : null;
  }

  constructor(gl) {
    this.gl = gl;
    this.buffer = gl.createBuffer();
    this.fill = this.program(FILL_VERTEX, FILL_FRAGMENT);
    this.stroke = this.program(STROKE_VERTEX, STROKE_FRAGMENT);
  }

  program(vertex, fragment) {
    const gl = this.gl;
    const shader = (type, src) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vertex));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fragment));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    return { p, size: gl.getUniformLocation(p, 'size'), vao: gl.createVertexArray() };
  }

  // The instanced attributes of `prog` from `offset` in the buffer: [name, floats] then colour.
  bind(prog, offset, stride, floats) {
    const gl = this.gl;
    gl.bindVertexArray(prog.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffer);
    let at = offset;
    for (const [name, n] of floats) {
      const loc = gl.getAttribLocation(prog.p, name);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, n, gl.FLOAT, false, stride, at);
      gl.vertexAttribDivisor(loc, 1);
      at += 4 * n;
    }
    const loc = gl.getAttribLocation(prog.p, 'color');
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 4, gl.UNSIGNED_BYTE, true, stride, at);
    gl.vertexAttribDivisor(loc, 1);
  }

  // Draws the frame ({buffer, strokes, fills}); returns {uploadMs, callsMs, finishMs} (finish:
  // with `finish`, one pixel read back, which waits until the browser has rasterized the draws).
  draw(frame, width, height, finish) {
    const gl = this.gl;
    const canvas = gl.canvas;
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
    }
    const t0 = performance.now();
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffer);
    gl.bufferData(gl.ARRAY_BUFFER, frame.buffer, gl.STREAM_DRAW);
    const t1 = performance.now();
    gl.viewport(0, 0, width, height);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    for (const [prog, count, vertices, offset, stride, floats] of [
      [this.stroke, frame.strokes, 6, 0, STROKE_BYTES, [['a', 2], ['b', 2]]],
      [this.fill, frame.fills, 3, frame.strokes * STROKE_BYTES, FILL_BYTES, [['c0', 2], ['c1', 2], ['c2', 2]]],
    ]) {
      if (!count) continue;
      gl.useProgram(prog.p);
      gl.uniform2f(prog.size, width, height);
      this.bind(prog, offset, stride, floats);
      gl.drawArraysInstanced(gl.TRIANGLES, 0, vertices, count);
    }
    gl.bindVertexArray(null);
    const t2 = performance.now();
    if (finish) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    return { uploadMs: t1 - t0, callsMs: t2 - t1, finishMs: performance.now() - t2 };
  }
}
