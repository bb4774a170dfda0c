// octolux view: the scene drawn with WebGL2 and lit by the octree of incident radiance,
// evaluated per fragment on the GPU (the CPU's §7 query: the leaves meeting a box of side
// alpha × the smallest leaf's edge around the point, weighted by their overlap volumes, per
// axis over the leaves whose matrix carries a value, the paper's 36-byte matrices decoded in
// the shader). The octree arrives in chunks (/octree/K.bin: the root, then splits, each the
// 8 children of a node already sent): every prefix is a complete coarser octree, drawn as it
// comes. See crates/octolux-io/src/view/mod.rs for the data.
'use strict';

const VS = `#version 300 es
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec3 aNrm;
layout(location = 2) in vec3 aAlb;
layout(location = 3) in vec3 aEmit;
uniform vec3 uOrigin, uLeft, uUp, uFwd;
uniform vec2 uTan, uNearFar;
out vec3 vPos; out vec3 vNrm; out vec3 vAlb; out vec3 vEmit;
void main() {
  vec3 r = aPos - uOrigin;
  float l = dot(r, uLeft), u = dot(r, uUp), f = dot(r, uFwd);
  float n = uNearFar.x, fa = uNearFar.y;
  gl_Position = vec4(-l / uTan.x, u / uTan.y, (f * (fa + n) - 2.0 * fa * n) / (fa - n), f);
  vPos = aPos; vNrm = aNrm; vAlb = aAlb; vEmit = aEmit;
}`;

const FS = `#version 300 es
precision highp float; precision highp int; precision highp usampler2D;
// two octrees, global (indirect) and direct light, each as two integer textures:
// nodes: per node x = first child (0xffffffff: a leaf of this prefix), y = kind | facing << 8;
// values: per node 9 words, the 36 bytes of its six matrices
uniform usampler2D uNodes, uValues, uDNodes, uDValues;
uniform vec3 uRootMin, uDRootMin; uniform float uRootSize, uDRootSize, uHalf, uDHalf; uniform int uMode;
uniform vec3 uOrigin; uniform float uExposure; uniform float uMaxDepth; uniform bool uDisplay;
in vec3 vPos; in vec3 vNrm; in vec3 vAlb; in vec3 vEmit;
out vec4 outColor;
const int TW = 4096;
const uint LEAF = 0xffffffffu;
uvec2 node(usampler2D t, uint i) { return texelFetch(t, ivec2(int(i) % TW, int(i) / TW), 0).xy; }
uint word(usampler2D t, uint i) { return texelFetch(t, ivec2(int(i) % TW, int(i) / TW), 0).x; }
uint byteAt(usampler2D t, uint b) { return (word(t, b >> 2u) >> ((b & 3u) * 8u)) & 255u; }
const float PI = 3.14159265358979;
// matrix k of node i, applied to n: C (D . n)
vec3 term(usampler2D t, uint i, uint k, vec3 n) {
  uint b = i * 36u + k * 6u;
  float th = (float(byteAt(t, b)) + 0.5) * PI / 256.0;
  float ph = (float(byteAt(t, b + 1u)) + 0.5) * 2.0 * PI / 256.0;
  vec3 d = vec3(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
  uint e = byteAt(t, b + 5u);
  if (e == 0u) return vec3(0.0);
  vec3 c = (vec3(float(byteAt(t, b + 2u)), float(byteAt(t, b + 3u)), float(byteAt(t, b + 4u))) + 0.5) * exp2(float(e) - 136.0);
  return c * dot(d, n);
}
uint stN[128]; uint stD[128]; uvec3 stI[128];
// the §7 blend at p for the unit normal n; w < 0: no leaf answered
vec4 irradiance(usampler2D nodes, usampler2D vals, vec3 rootMin, float rootSize, float half_, vec3 p, vec3 n) {
  uint sel[3] = uint[3](n.x >= 0.0 ? 0u : 1u, n.y >= 0.0 ? 2u : 3u, n.z >= 0.0 ? 4u : 5u);
  vec3 wn = n * n;
  vec3 sum[3] = vec3[3](vec3(0.0), vec3(0.0), vec3(0.0));
  vec3 wsum = vec3(0.0);
  vec3 qmin = p - vec3(half_), qmax = p + vec3(half_);
  vec3 rmax = rootMin + vec3(rootSize);
  if (!(all(lessThan(qmin, rmax)) && all(greaterThan(qmax, rootMin)))) return vec4(0.0, 0.0, 0.0, -1.0);
  int sp = 0;
  stN[0] = 0u; stD[0] = 0u; stI[0] = uvec3(0u); sp = 1;
  for (int guard = 0; guard < 4096 && sp > 0; guard++) {
    sp--;
    uint i = stN[sp]; uint depth = stD[sp]; uvec3 ijk = stI[sp];
    float edge = rootSize / exp2(float(depth));
    vec3 cmin = rootMin + vec3(ijk) * edge;
    uvec2 nd = node(nodes, i);
    if (nd.x == LEAF) {
      uint kind = nd.y & 255u;
      if (kind == 2u) continue;
      vec3 o = min(cmin + vec3(edge), qmax) - max(cmin, qmin);
      float g = o.x * o.y * o.z;
      uint facing = nd.y >> 8u;
      for (int a = 0; a < 3; a++) {
        if ((facing & (1u << sel[a])) != 0u) {
          sum[a] += term(vals, i, sel[a], n) * g;
          wsum[a] += g;
        }
      }
      continue;
    }
    float cedge = edge * 0.5;
    vec3 mid = rootMin + vec3(ijk * 2u + 1u) * cedge;
    // children in reverse order, so that they are met in the CPU's order
    for (int c = 7; c >= 0; c--) {
      uvec3 b = uvec3(uint(c) & 1u, (uint(c) >> 1u) & 1u, (uint(c) >> 2u) & 1u);
      bvec3 upper = equal(b, uvec3(1u));
      bvec3 ok = bvec3(upper.x ? qmax.x > mid.x : qmin.x < mid.x,
                       upper.y ? qmax.y > mid.y : qmin.y < mid.y,
                       upper.z ? qmax.z > mid.z : qmin.z < mid.z);
      if (all(ok) && sp < 128) {
        stN[sp] = nd.x + uint(c); stD[sp] = depth + 1u; stI[sp] = ijk * 2u + b; sp++;
      }
    }
  }
  vec3 outE = vec3(0.0); float norm = 0.0; bool any = false;
  for (int a = 0; a < 3; a++) {
    if (wsum[a] > 0.0) {
      any = true;
      if (wn[a] > 0.0) { outE += sum[a] * (wn[a] / wsum[a]); norm += wn[a]; }
    }
  }
  if (!any) return vec4(0.0, 0.0, 0.0, -1.0);
  return vec4(norm > 0.0 ? max(outE / norm, vec3(0.0)) : vec3(0.0), 1.0);
}
// linear to the display's sRGB on the canvas; linear into the float target read back
vec3 srgb(vec3 c) {
  if (!uDisplay) return c;
  c = clamp(c, 0.0, 1.0);
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
vec3 hsv(float h, float s, float v) {
  vec3 k = mod(vec3(5.0, 3.0, 1.0) + h * 6.0, 6.0);
  return v - v * s * clamp(min(k, 4.0 - k), 0.0, 1.0);
}
// the prefix's leaf holding p, as the depth it lies at (-1 outside, -2 atmospheric)
float leafDepth(vec3 p) {
  vec3 rel = (p - uRootMin) / uRootSize;
  if (any(lessThan(rel, vec3(0.0))) || any(greaterThanEqual(rel, vec3(1.0)))) return -1.0;
  uint i = 0u;
  for (int depth = 0; depth < 24; depth++) {
    uvec2 nd = node(uNodes, i);
    if (nd.x == LEAF) return (nd.y & 255u) == 2u ? -2.0 : float(depth);
    vec3 s = floor(rel * exp2(float(depth + 1)));
    uvec3 b = uvec3(mod(s, 2.0));
    i = nd.x + b.x + 2u * b.y + 4u * b.z;
  }
  return -1.0;
}
void main() {
  vec3 n = normalize(vNrm);
  // an emitter's radiance, seen from its emitting side (the side its normal faces)
  vec3 le = dot(n, uOrigin - vPos) > 0.0 ? vEmit : vec3(0.0);
  if (dot(n, uOrigin - vPos) < 0.0) n = -n;
  if (uMode == 3) { outColor = vec4(length(vPos - uOrigin)); return; }
  if (uMode == 2) {
    float d = leafDepth(vPos);
    outColor = vec4(d == -2.0 ? vec3(0.02) : d < 0.0 ? vec3(0.0) : hsv(0.8 * d / max(uMaxDepth, 1.0), 0.7, 0.9), 1.0);
    return;
  }
  vec3 ei = irradiance(uNodes, uValues, uRootMin, uRootSize, uHalf, vPos, n).rgb;
  if (uMode == 1) { outColor = vec4(srgb(ei * uExposure), 1.0); return; }
  vec3 ed = irradiance(uDNodes, uDValues, uDRootMin, uDRootSize, uDHalf, vPos, n).rgb;
  vec3 c = uMode == 5 ? ed : uMode == 4 ? ei * vAlb / PI : (ed + ei) * vAlb / PI + le;
  outColor = vec4(srgb(c * uExposure), 1.0);
}`;

const TW = 4096;

function compile(gl, type, src) {
  const s = gl.createShader(type);
  gl.shaderSource(s, src);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error('shader: ' + gl.getShaderInfoLog(s));
  return s;
}

function uintTexture(gl, format, internal, comps, data, count) {
  const rows = Math.max(1, Math.ceil(count / TW));
  const padded = new Uint32Array(TW * rows * comps);
  padded.set(data.subarray(0, count * comps));
  const t = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, t);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texImage2D(gl.TEXTURE_2D, 0, internal, TW, rows, 0, format, gl.UNSIGNED_INT, padded);
  return t;
}

async function fetchBin(path) {
  const r = await fetch(path);
  if (!r.ok) throw new Error(path + ': ' + r.status);
  return new Uint8Array(await r.arrayBuffer());
}

(async function main() {
  const statusEl = document.getElementById('status');
  const say = (msg) => { statusEl.textContent = msg; };
  try {
    const meta = await (await fetch('/meta.json')).json();
    const canvas = document.getElementById('c');
    canvas.width = meta.width; canvas.height = meta.height;
    const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
    if (!gl) throw new Error('this browser has no WebGL2');
    const floatTarget = !!gl.getExtension('EXT_color_buffer_float');
    const prog = gl.createProgram();
    gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error('link: ' + gl.getProgramInfoLog(prog));
    gl.useProgram(prog);
    const U = (name) => gl.getUniformLocation(prog, name);

    // the scene: per vertex position, normal, albedo, emitted radiance (12 f32)
    const sceneBytes = await fetchBin('/scene.bin');
    const verts = new Float32Array(sceneBytes.buffer, sceneBytes.byteOffset, sceneBytes.byteLength / 4);
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const vbo = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vbo);
    gl.bufferData(gl.ARRAY_BUFFER, verts, gl.STATIC_DRAW);
    for (let a = 0; a < 4; a++) {
      gl.enableVertexAttribArray(a);
      gl.vertexAttribPointer(a, 3, gl.FLOAT, false, 48, 12 * a);
    }
    const vertexCount = verts.length / 12;

    // the camera: the scene's, then the user's
    const home = meta.camera;
    let cam = JSON.parse(JSON.stringify(home));
    const b = meta.bounds;
    const diag = Math.hypot(b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]);
    const sub = (a, c) => [a[0] - c[0], a[1] - c[1], a[2] - c[2]];
    const add = (a, c, s) => [a[0] + c[0] * s, a[1] + c[1] * s, a[2] + c[2] * s];
    const dot = (a, c) => a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
    const cross = (a, c) => [a[1] * c[2] - a[2] * c[1], a[2] * c[0] - a[0] * c[2], a[0] * c[1] - a[1] * c[0]];
    const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };
    const centre = [(b.min[0] + b.max[0]) / 2, (b.min[1] + b.max[1]) / 2, (b.min[2] + b.max[2]) / 2];
    let target = add(cam.origin, cam.forward, Math.max(1e-3, dot(sub(centre, cam.origin), cam.forward)));
    const worldUp = home.up;
    function lookFrom(origin) {
      const fwd = norm(sub(target, origin));
      let left = cross(worldUp, fwd);
      if (Math.hypot(...left) < 1e-6) left = cam.left;
      left = norm(left);
      cam.origin = origin; cam.forward = fwd; cam.left = left; cam.up = cross(fwd, left);
    }

    // the octrees, as they arrive: a placeholder root without value until the first chunk
    function makeTree(m) {
      const t = { m, nodes: new Uint32Array(Math.max(m.nodes, 1) * 2), values: new Uint32Array(Math.max(m.nodes, 1) * 9),
        have: 0, half: 0, depth: 0, nodeTex: null, valueTex: null };
      t.valueBytes = new Uint8Array(t.values.buffer);
      t.nodes[0] = 0xffffffff; t.nodes[1] = 2;
      upload(t, 1);
      return t;
    }
    function upload(t, count) {
      if (t.nodeTex) gl.deleteTexture(t.nodeTex);
      if (t.valueTex) gl.deleteTexture(t.valueTex);
      t.nodeTex = uintTexture(gl, gl.RG_INTEGER, gl.RG32UI, 2, t.nodes, count);
      t.valueTex = uintTexture(gl, gl.RED_INTEGER, gl.R32UI, 1, t.values, count * 9);
    }
    // one chunk's bytes into the tree (view/mod.rs): the root, or splits
    function addChunk(t, k, data) {
      let at = 0;
      const node = (i) => {
        if (i >= t.m.nodes) throw new Error('node ' + i + ' past the ' + t.m.nodes + ' announced');
        const kind = data[at], facing = data[at + 1];
        at += 2;
        t.nodes[2 * i] = 0xffffffff;
        t.nodes[2 * i + 1] = kind | (facing << 8);
        if (kind !== 2) { t.valueBytes.set(data.subarray(at, at + 36), 36 * i); at += 36; }
      };
      if (k === 0) {
        node(0);
        t.have = 1;
      } else {
        const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
        while (at < data.length) {
          const parent = view.getUint32(at, true);
          at += 4;
          if (parent >= t.have || (t.nodes[2 * parent + 1] & 255) !== 0 || t.nodes[2 * parent] !== 0xffffffff) {
            throw new Error('chunk ' + k + ': a split of node ' + parent);
          }
          t.nodes[2 * parent] = t.have;
          for (let c = 0; c < 8; c++) node(t.have + c);
          t.have += 8;
        }
      }
      if (at !== data.length) throw new Error('chunk ' + k + ': ' + data.length + ' bytes, ' + at + ' read');
      const edge = t.m.chunks[k].edge;
      t.half = 0.5 * t.m.alpha * edge;
      t.depth = Math.round(Math.log2(t.m.size / edge));
      upload(t, t.have);
    }
    const indirect = makeTree(meta.tree), direct = makeTree(meta.direct);
    const chunks = meta.tree.chunks;
    gl.uniform3fv(U('uRootMin'), meta.tree.origin);
    gl.uniform1f(U('uRootSize'), meta.tree.size);
    gl.uniform3fv(U('uDRootMin'), meta.direct.origin);
    gl.uniform1f(U('uDRootSize'), meta.direct.size);
    gl.uniform1i(U('uNodes'), 0);
    gl.uniform1i(U('uValues'), 1);
    gl.uniform1i(U('uDNodes'), 2);
    gl.uniform1i(U('uDValues'), 3);
    const far = 4 * diag + 1;

    function draw(mode, exposure, display = true) {
      gl.viewport(0, 0, meta.width, meta.height);
      gl.enable(gl.DEPTH_TEST);
      gl.disable(gl.CULL_FACE);
      gl.clearColor(0, 0, 0, 1);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      gl.uniform3fv(U('uOrigin'), cam.origin);
      gl.uniform3fv(U('uLeft'), cam.left);
      gl.uniform3fv(U('uUp'), cam.up);
      gl.uniform3fv(U('uFwd'), cam.forward);
      gl.uniform2f(U('uTan'), cam.tan_half_x, cam.tan_half_y);
      gl.uniform2f(U('uNearFar'), Math.max(cam.near_clip, diag * 1e-4), far);
      gl.uniform1f(U('uHalf'), indirect.half);
      gl.uniform1f(U('uDHalf'), direct.half);
      gl.uniform1i(U('uMode'), mode);
      gl.uniform1i(U('uDisplay'), display ? 1 : 0);
      gl.uniform1f(U('uExposure'), exposure);
      gl.uniform1f(U('uMaxDepth'), indirect.depth);
      gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, indirect.nodeTex);
      gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, indirect.valueTex);
      gl.activeTexture(gl.TEXTURE2); gl.bindTexture(gl.TEXTURE_2D, direct.nodeTex);
      gl.activeTexture(gl.TEXTURE3); gl.bindTexture(gl.TEXTURE_2D, direct.valueTex);
      gl.drawArrays(gl.TRIANGLES, 0, vertexCount);
    }

    const modeEl = document.getElementById('mode');
    const expEl = document.getElementById('exposure');
    // the view and the exposure may come in the address: /?mode=2&exposure=1.5
    const params = new URLSearchParams(location.search);
    if (params.has('mode')) modeEl.value = params.get('mode');
    if (params.has('exposure')) expEl.value = params.get('exposure');
    const redraw = () => draw(+modeEl.value, Math.pow(2, +expEl.value));
    modeEl.onchange = redraw; expEl.oninput = redraw;

    // irradiance (mode 1) or distance (mode 3) into a float target, read back (rows bottom first)
    let fbo = null;
    function readIrradiance(mode = 1) {
      if (!floatTarget) return null;
      if (!fbo) {
        fbo = gl.createFramebuffer();
        gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
        const tex = gl.createTexture();
        gl.bindTexture(gl.TEXTURE_2D, tex);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, meta.width, meta.height, 0, gl.RGBA, gl.FLOAT, null);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
        const depth = gl.createRenderbuffer();
        gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
        gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, meta.width, meta.height);
        gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
      }
      gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
      draw(mode, 1.0, false);
      const px = new Float32Array(meta.width * meta.height * 4);
      gl.readPixels(0, 0, meta.width, meta.height, gl.RGBA, gl.FLOAT, px);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      return px;
    }

    // relMSE of a against r (RGB of RGBA rows bottom first, against RGB rows top first), as
    // octolux's metrics: (a - r)² / (r² + 1e-2), and the ratio of the means, over the pixels
    // `use` keeps (all by default)
    const W = meta.width, H = meta.height;
    function compare(a, rTopFirst, use = null) {
      let s = 0, ma = 0, mr = 0, worst = [0, 0, 0], n = 0;
      for (let y = 0; y < H; y++) {
        for (let x = 0; x < W; x++) {
          if (use && !use[y * W + x]) continue;
          n++;
          const ia = ((H - 1 - y) * W + x) * 4, ir = (y * W + x) * 3;
          let p = 0;
          for (let c = 0; c < 3; c++) {
            const d = a[ia + c] - rTopFirst[ir + c];
            p += d * d / (rTopFirst[ir + c] * rTopFirst[ir + c] + 1e-2);
            ma += a[ia + c]; mr += rTopFirst[ir + c];
          }
          s += p;
          if (p > worst[2]) worst = [x, y, p];
        }
      }
      return { relmse: s / (3 * Math.max(n, 1)), ratio: mr > 0 ? ma / mr : 0, worst, pixels: n };
    }
    const toTopFirst = (a) => {
      const out = new Float32Array(W * H * 3);
      for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) for (let c = 0; c < 3; c++)
        out[(y * W + x) * 3 + c] = a[((H - 1 - y) * W + x) * 4 + c];
      return out;
    };

    // the CPU's irradiance (RGB) and surface distance per pixel
    let cpu = null, cpuDist = null;
    if (meta.compare_cpu) {
      const raw = new Float32Array((await fetchBin('/cpu.bin')).buffer);
      cpu = new Float32Array(W * H * 3);
      cpuDist = new Float32Array(W * H);
      for (let i = 0; i < W * H; i++) {
        for (let c = 0; c < 3; c++) cpu[3 * i + c] = raw[4 * i + c];
        cpuDist[i] = raw[4 * i + 3];
      }
    }
    const total = chunks.reduce((s, l) => s + l.bytes, 0);
    let received = 0;
    const curve = [];
    const shots = [];
    let firstPictureBytes = null;
    for (let k = 0; k < chunks.length; k++) {
      const data = await fetchBin('/octree/' + k + '.bin');
      received += data.length;
      addChunk(indirect, k, data);
      redraw();
      if (firstPictureBytes === null) firstPictureBytes = received;
      say('indirect light: ' + received + ' of ' + total + ' bytes');
      const shot = readIrradiance();
      if (shot) shots.push({ bytes: received, img: toTopFirst(shot) });
      await new Promise((r) => setTimeout(r, 0));
    }
    for (let k = 0; k < meta.direct.chunks.length; k++) {
      addChunk(direct, k, await fetchBin('/direct/' + k + '.bin'));
      redraw();
      say('direct light: chunk ' + (k + 1) + ' of ' + meta.direct.chunks.length);
      await new Promise((r) => setTimeout(r, 0));
    }
    const out = { chunks: chunks.length, bytes: total, first_picture_bytes: firstPictureBytes, float_target: floatTarget,
      direct_bytes: meta.direct.chunks.reduce((s, l) => s + l.bytes, 0) };
    if (shots.length) {
      const last = shots[shots.length - 1].img;
      const asRgba = (t) => {
        const o = new Float32Array(W * H * 4);
        for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) for (let c = 0; c < 3; c++)
          o[((H - 1 - y) * W + x) * 4 + c] = t[(y * W + x) * 3 + c];
        return o;
      };
      for (const s of shots) curve.push([s.bytes, compare(asRgba(s.img), last).relmse]);
      out.curve = curve;
      if (cpu) {
        // the pixels where the page drew the CPU's surface point (the same distance to 0.5%)
        const dist = readIrradiance(3);
        const use = new Uint8Array(W * H);
        for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
          const t = cpuDist[y * W + x], g = dist[((H - 1 - y) * W + x) * 4];
          use[y * W + x] = (t === 0 && g === 0) || (t > 0 && Math.abs(g - t) <= 5e-3 * t) ? 1 : 0;
        }
        const c = compare(asRgba(last), cpu, use);
        out.cpu_relmse = c.relmse;
        out.cpu_mean_ratio = c.ratio;
        out.cpu_worst_pixel = c.worst;
        out.cpu_pixels_compared = c.pixels / (W * H);
      }
    }
    // frame time: the full shading, 10 frames, timed by the server between two marks (the
    // page's own clock stops under a headless browser's virtual time); a one-pixel read waits
    // for the GPU
    await fetch('/mark?begin');
    for (let i = 0; i < 10; i++) draw(0, 1.0);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    await fetch('/mark?end&frames=10');
    redraw();
    for (const [k, v] of Object.entries(out)) document.body.dataset[k.replace(/_([a-z])/g, (_, c) => c.toUpperCase())] = JSON.stringify(v);
    say('the whole octree: ' + total + ' bytes, ' + meta.tree.nodes + ' nodes');
    document.body.dataset.status = 'ok';
    const q = Object.entries(out).map(([k, v]) => k + '=' + encodeURIComponent(JSON.stringify(v))).join('&');
    fetch('/done?' + q).catch(() => {});

    // controls
    let drag = null;
    canvas.onmousedown = (e) => { drag = [e.clientX, e.clientY]; canvas.style.cursor = 'grabbing'; };
    window.onmouseup = () => { drag = null; canvas.style.cursor = 'grab'; };
    window.onmousemove = (e) => {
      if (!drag) return;
      const dx = (e.clientX - drag[0]) * 0.01, dy = (e.clientY - drag[1]) * 0.01;
      drag = [e.clientX, e.clientY];
      let r = sub(cam.origin, target);
      const dist = Math.hypot(...r);
      // yaw about the world up, pitch about the camera's left
      const rot = (v, axis, ang) => {
        const c = Math.cos(ang), s = Math.sin(ang), k = norm(axis);
        const kv = cross(k, v), kd = dot(k, v);
        return [0, 1, 2].map((i) => v[i] * c + kv[i] * s + k[i] * kd * (1 - c));
      };
      r = rot(r, worldUp, -dx);
      r = rot(r, cam.left, dy);
      lookFrom(add(target, norm(r), dist));
      redraw();
    };
    canvas.onwheel = (e) => {
      e.preventDefault();
      cam.origin = add(target, sub(cam.origin, target), Math.exp(e.deltaY * 0.001));
      redraw();
    };
    window.onkeydown = (e) => {
      const step = diag * 0.02;
      const moves = { w: cam.forward, s: cam.forward.map((x) => -x), a: cam.left, d: cam.left.map((x) => -x), e: cam.up, q: cam.up.map((x) => -x) };
      const m = moves[e.key.toLowerCase()];
      if (m) { cam.origin = add(cam.origin, m, step); target = add(target, m, step); redraw(); }
      if (e.key.toLowerCase() === 'r') { cam = JSON.parse(JSON.stringify(home)); target = add(cam.origin, cam.forward, Math.max(1e-3, dot(sub(centre, cam.origin), cam.forward))); redraw(); }
    };
  } catch (err) {
    say('error: ' + err.message);
    document.body.dataset.status = 'error';
    document.body.dataset.error = err.message;
    fetch('/done?error=' + encodeURIComponent(JSON.stringify(err.message))).catch(() => {});
  }
})();
