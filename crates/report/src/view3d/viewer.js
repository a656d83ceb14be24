// The report's interactive view of the closed valve: plain WebGL 1, no
// library, reading the payload the report stage wrote beside it
// (src/report/view3d/pack.rs). Orthographic orbit about the valve axis, so
// the axis stays upright as in the static side view; Lambert shading with a
// headlight; the translucent wall drawn after the leaflets, depth writes off.
(function () {
  'use strict';
  var canvas = document.getElementById('view3d-canvas');
  var msg = document.getElementById('view3d-msg');
  var resetButton = document.getElementById('view3d-reset');

  function fail(text) {
    msg.textContent = text;
    msg.hidden = false;
    resetButton.hidden = true;
    canvas.setAttribute('data-state', 'unavailable');
  }

  function bytes(b64) {
    var s = atob(b64);
    var out = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }

  // The inverse of pack.rs's delta_varint, in double arithmetic (exact to
  // 2^53; bitwise operators would stop at 2^31).
  function undelta(b64, stride, out) {
    var b = bytes(b64);
    var k = 0, z = 0, scale = 1;
    for (var i = 0; i < b.length; i++) {
      z += (b[i] & 127) * scale;
      if (b[i] & 128) {
        scale *= 128;
        continue;
      }
      var d = z % 2 ? -(z + 1) / 2 : z / 2;
      out[k] = k >= stride ? out[k - stride] + d : d;
      k += 1;
      z = 0;
      scale = 1;
    }
    return out;
  }

  function positions(part, baseMm) {
    var xyz = undelta(part.positions, 3, new Float64Array(3 * part.vertices));
    var q = baseMm * Math.pow(2, part.quantum_exp);
    var out = new Float32Array(xyz.length);
    for (var i = 0; i < out.length; i++) out[i] = xyz[i] * q;
    return out;
  }

  function wide(part) {
    return part.vertices > 65536;
  }

  function indices(part) {
    var n = 3 * part.triangles;
    return undelta(part.indices, 1, wide(part) ? new Uint32Array(n) : new Uint16Array(n));
  }

  // Area-weighted vertex normals; the sign does not matter, shading is two-sided.
  function normals(p, idx) {
    var n = new Float32Array(p.length);
    for (var t = 0; t < idx.length; t += 3) {
      var a = 3 * idx[t], b = 3 * idx[t + 1], c = 3 * idx[t + 2];
      var ux = p[b] - p[a], uy = p[b + 1] - p[a + 1], uz = p[b + 2] - p[a + 2];
      var vx = p[c] - p[a], vy = p[c + 1] - p[a + 1], vz = p[c + 2] - p[a + 2];
      var nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      for (var k = 0; k < 3; k++) {
        var o = 3 * idx[t + k];
        n[o] += nx; n[o + 1] += ny; n[o + 2] += nz;
      }
    }
    for (var i = 0; i < n.length; i += 3) {
      var l = Math.sqrt(n[i] * n[i] + n[i + 1] * n[i + 1] + n[i + 2] * n[i + 2]) || 1;
      n[i] /= l; n[i + 1] /= l; n[i + 2] /= l;
    }
    return n;
  }

  var VERTEX = [
    'attribute vec3 aPos;',
    'attribute vec3 aNormal;',
    'attribute vec3 aClass;',
    'attribute vec3 aTint;',
    'uniform mat3 uRot;',
    'uniform vec3 uCentre;',
    'uniform vec2 uScale;',
    'uniform float uDepth;',
    'varying vec3 vNormal;',
    'varying vec3 vClass;',
    'varying vec3 vTint;',
    'void main() {',
    '  vec3 e = uRot * (aPos - uCentre);',
    '  vNormal = uRot * aNormal;',
    '  vClass = aClass;',
    '  vTint = aTint;',
    '  gl_Position = vec4(e.xy * uScale, -e.z * uDepth, 1.0);',
    '}'
  ].join('\n');

  // The contact class is interpolated one-hot and the largest weight wins,
  // ties to the stronger contact: zone borders fall halfway along edges,
  // as in the static views.
  var FRAGMENT = [
    'precision mediump float;',
    'uniform vec3 uPair;',
    'uniform vec3 uTriple;',
    'uniform vec4 uWall;',
    'uniform float uIsWall;',
    'varying vec3 vNormal;',
    'varying vec3 vClass;',
    'varying vec3 vTint;',
    'void main() {',
    '  vec3 base = vTint;',
    '  float best = vClass.x;',
    '  if (vClass.y >= best) { base = uPair; best = vClass.y; }',
    '  if (vClass.z >= best) { base = uTriple; }',
    '  float alpha = 1.0;',
    '  if (uIsWall > 0.5) { base = uWall.rgb; alpha = uWall.a; }',
    '  float lambert = abs(normalize(vNormal).z);',
    '  gl_FragColor = vec4(base * (0.3 + 0.7 * lambert), alpha);',
    '}'
  ].join('\n');

  var data;
  try {
    data = JSON.parse(document.getElementById('view3d-data').textContent);
  } catch (e) {
    fail('The data of the interactive view cannot be read; the static figures below show the valve.');
    return;
  }
  if (data.format !== 'coapt-view3d/1') {
    fail('The interactive view does not know this data format (' + data.format + '); the static figures below show the valve.');
    return;
  }

  var gl = null;
  try {
    gl = canvas.getContext('webgl', { alpha: false, antialias: true }) ||
      canvas.getContext('experimental-webgl', { alpha: false, antialias: true });
  } catch (e) {
    gl = null;
  }
  if (!gl) {
    fail('WebGL is not available in this browser, so the interactive view cannot be drawn; the static figures below show the same valve.');
    return;
  }
  var needWide = wide(data.leaflets) || (data.wall && wide(data.wall));
  if (needWide && !gl.getExtension('OES_element_index_uint')) {
    fail('This browser\'s WebGL cannot draw meshes of more than 65536 vertices; the static figures below show the valve.');
    return;
  }

  function shader(type, src) {
    var s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    return gl.getShaderParameter(s, gl.COMPILE_STATUS) ? s : null;
  }
  var vs = shader(gl.VERTEX_SHADER, VERTEX);
  var fs = shader(gl.FRAGMENT_SHADER, FRAGMENT);
  var prog = gl.createProgram();
  if (vs && fs) {
    gl.attachShader(prog, vs);
    gl.attachShader(prog, fs);
    // Location 0 always has an array: some drivers draw nothing otherwise.
    gl.bindAttribLocation(prog, 0, 'aPos');
    gl.linkProgram(prog);
  }
  if (!vs || !fs || !gl.getProgramParameter(prog, gl.LINK_STATUS)) {
    fail('This browser\'s WebGL could not prepare the view\'s shaders; the static figures below show the valve.');
    return;
  }
  gl.useProgram(prog);
  var loc = {};
  ['aPos', 'aNormal', 'aClass', 'aTint'].forEach(function (a) { loc[a] = gl.getAttribLocation(prog, a); });
  ['uRot', 'uCentre', 'uScale', 'uDepth', 'uPair', 'uTriple', 'uWall', 'uIsWall'].forEach(function (u) {
    loc[u] = gl.getUniformLocation(prog, u);
  });

  function buffer(target, array) {
    var b = gl.createBuffer();
    gl.bindBuffer(target, b);
    gl.bufferData(target, array, gl.STATIC_DRAW);
    return b;
  }

  var baseMm = data.base_quantum_um / 1000;
  function mesh(part) {
    var p = positions(part, baseMm);
    var idx = indices(part);
    return {
      p: p,
      count: idx.length,
      type: wide(part) ? gl.UNSIGNED_INT : gl.UNSIGNED_SHORT,
      pos: buffer(gl.ARRAY_BUFFER, p),
      nrm: buffer(gl.ARRAY_BUFFER, normals(p, idx)),
      idx: buffer(gl.ELEMENT_ARRAY_BUFFER, idx)
    };
  }

  var leaflets = mesh(data.leaflets);
  // Per vertex: one-hot contact class and the leaflet's tint, from its code.
  var codes = bytes(data.leaflets.codes);
  var cls = new Float32Array(3 * codes.length);
  var tint = new Float32Array(3 * codes.length);
  var tints = data.colours.leaflets;
  for (var i = 0; i < codes.length; i++) {
    cls[3 * i + (codes[i] & 3)] = 1;
    var c = tints[(codes[i] >> 2) % tints.length];
    for (var k = 0; k < 3; k++) tint[3 * i + k] = c[k] / 255;
  }
  leaflets.cls = buffer(gl.ARRAY_BUFFER, cls);
  leaflets.tint = buffer(gl.ARRAY_BUFFER, tint);
  var wall = data.wall ? mesh(data.wall) : null;

  // Rotation centre: the middle of the leaflets' bounding box; the view is
  // fitted to everything drawn.
  var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (i = 0; i < leaflets.p.length; i++) {
    lo[i % 3] = Math.min(lo[i % 3], leaflets.p[i]);
    hi[i % 3] = Math.max(hi[i % 3], leaflets.p[i]);
  }
  var centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
  var radius = 1e-3;
  [leaflets, wall].forEach(function (m) {
    if (!m) return;
    for (var j = 0; j < m.p.length; j += 3) {
      var dx = m.p[j] - centre[0], dy = m.p[j + 1] - centre[1], dz = m.p[j + 2] - centre[2];
      radius = Math.max(radius, Math.sqrt(dx * dx + dy * dy + dz * dz));
    }
  });

  // Viewer opposite C1 looking towards it, axis up (the static side view),
  // raised 30 degrees to look into the closed valve from the aorta side.
  var HOME = { yaw: 0, pitch: Math.PI / 6, zoom: 1 };
  var view = { yaw: HOME.yaw, pitch: HOME.pitch, zoom: HOME.zoom };

  // Rows of the rotation world -> eye: pitch about the eye's x after the
  // base map (x, y, z) -> (-y, z, -x) after yaw about the valve axis.
  function rotation() {
    var cy = Math.cos(view.yaw), sy = Math.sin(view.yaw);
    var cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
    var yaw = [[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]];
    var base = [[0, -1, 0], [0, 0, 1], [-1, 0, 0]];
    var pitch = [[1, 0, 0], [0, cp, -sp], [0, sp, cp]];
    function mul(a, b) {
      var r = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
      for (var i = 0; i < 3; i++) for (var j = 0; j < 3; j++) for (var k = 0; k < 3; k++) r[i][j] += a[i][k] * b[k][j];
      return r;
    }
    return mul(pitch, mul(base, yaw));
  }

  function setColour(name, rgb, a) {
    if (a === undefined) gl.uniform3f(loc[name], rgb[0] / 255, rgb[1] / 255, rgb[2] / 255);
    else gl.uniform4f(loc[name], rgb[0] / 255, rgb[1] / 255, rgb[2] / 255, a);
  }

  function attribute(name, buf) {
    if (loc[name] < 0) return;
    if (buf) {
      gl.bindBuffer(gl.ARRAY_BUFFER, buf);
      gl.enableVertexAttribArray(loc[name]);
      gl.vertexAttribPointer(loc[name], 3, gl.FLOAT, false, 0, 0);
    } else {
      gl.disableVertexAttribArray(loc[name]);
      gl.vertexAttrib3f(loc[name], 0, 0, 0);
    }
  }

  function drawMesh(m, isWall) {
    attribute('aPos', m.pos);
    attribute('aNormal', m.nrm);
    attribute('aClass', isWall ? null : m.cls);
    attribute('aTint', isWall ? null : m.tint);
    gl.uniform1f(loc.uIsWall, isWall ? 1 : 0);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, m.idx);
    gl.drawElements(gl.TRIANGLES, m.count, m.type, 0);
  }

  var frames = 0;
  function draw() {
    pending = false;
    var dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, Math.round(canvas.clientWidth * dpr));
    var h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (canvas.width !== w || canvas.height !== h) {
      canvas.width = w;
      canvas.height = h;
    }
    gl.viewport(0, 0, w, h);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    var r = rotation();
    // Column-major for WebGL.
    gl.uniformMatrix3fv(loc.uRot, false, [r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2]]);
    gl.uniform3f(loc.uCentre, centre[0], centre[1], centre[2]);
    var pxPerMm = view.zoom * 0.46 * Math.min(w, h) / radius;
    gl.uniform2f(loc.uScale, 2 * pxPerMm / w, 2 * pxPerMm / h);
    gl.uniform1f(loc.uDepth, 1 / (1.01 * radius));
    setColour('uPair', data.colours.pair);
    setColour('uTriple', data.colours.triple);
    setColour('uWall', data.colours.wall, 0.22);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LEQUAL);
    gl.disable(gl.BLEND);
    gl.depthMask(true);
    drawMesh(leaflets, false);
    if (wall) {
      gl.enable(gl.BLEND);
      gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
      gl.depthMask(false);
      drawMesh(wall, true);
      gl.depthMask(true);
    }
    frames += 1;
    canvas.setAttribute('data-frames', String(frames));
    canvas.setAttribute('data-state', 'drawn');
  }

  var pending = false;
  function redraw() {
    if (!pending) {
      pending = true;
      window.requestAnimationFrame(draw);
    }
  }

  var drag = null;
  canvas.addEventListener('pointerdown', function (e) {
    drag = { x: e.clientX, y: e.clientY };
    try { canvas.setPointerCapture(e.pointerId); } catch (err) { /* capture is a convenience */ }
    e.preventDefault();
  });
  canvas.addEventListener('pointermove', function (e) {
    if (!drag) return;
    view.yaw += 0.01 * (e.clientX - drag.x);
    view.pitch = Math.max(-Math.PI / 2, Math.min(Math.PI / 2, view.pitch + 0.01 * (e.clientY - drag.y)));
    drag = { x: e.clientX, y: e.clientY };
    redraw();
  });
  function endDrag() { drag = null; }
  canvas.addEventListener('pointerup', endDrag);
  canvas.addEventListener('pointercancel', endDrag);
  canvas.addEventListener('wheel', function (e) {
    e.preventDefault();
    view.zoom = Math.max(0.2, Math.min(20, view.zoom * Math.exp(-0.0015 * e.deltaY)));
    redraw();
  }, { passive: false });
  resetButton.addEventListener('click', function () {
    view.yaw = HOME.yaw;
    view.pitch = HOME.pitch;
    view.zoom = HOME.zoom;
    redraw();
  });
  canvas.addEventListener('webglcontextlost', function (e) {
    e.preventDefault();
    fail('The browser took the WebGL context away; reload the page to see the interactive view again.');
  });
  window.addEventListener('resize', redraw);
  resetButton.disabled = false;
  msg.hidden = true;
  redraw();
})();
