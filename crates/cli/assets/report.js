"use strict";
// focal compare report viewer: decodes each image's half floats, tonemaps on a canvas (exposure, sRGB),
// shows a split view of two images, zoomed crops of all images at a chosen point, and runs a self-test
// of the slider when the page is opened with #selftest.
(function () {
  const errors = [];
  window.addEventListener("error", (e) => {
    errors.push(e.message || ("failed to load " + ((e.target && (e.target.src || e.target.href)) || "a resource")));
  }, true);

  function halfToFloat(h) {
    const s = (h & 0x8000) ? -1 : 1, e = (h >> 10) & 0x1f, f = h & 0x3ff;
    if (e === 0) return s * f * Math.pow(2, -24);
    if (e === 31) return f ? 0 : s * 65504;
    return s * (1 + f / 1024) * Math.pow(2, e - 15);
  }
  const HALF = new Float32Array(65536);
  for (let i = 0; i < 65536; i++) HALF[i] = halfToFloat(i);

  function decode(entry) {
    const bin = atob(entry.f16);
    const n = bin.length >> 1;
    const out = new Float32Array(n);
    for (let i = 0; i < n; i++) out[i] = HALF[bin.charCodeAt(2 * i) | (bin.charCodeAt(2 * i + 1) << 8)];
    return { w: entry.w, h: entry.h, rgb: out };
  }

  const LUT_SIZE = 4096;
  const SRGB = new Uint8ClampedArray(LUT_SIZE + 1);
  for (let i = 0; i <= LUT_SIZE; i++) {
    const v = i / LUT_SIZE;
    const s = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
    SRGB[i] = Math.floor(s * 255 + 0.5);
  }
  function tone(v, scale) {
    const x = v * scale;
    if (!(x > 0)) return 0;
    return SRGB[x >= 1 ? LUT_SIZE : Math.floor(x * LUT_SIZE + 0.5)];
  }

  const data = window.FOCAL_DATA || {};
  const images = [];
  for (const m of FOCAL_IMAGES) {
    if (!data[m.key]) { errors.push("missing image data " + m.key); continue; }
    images.push(Object.assign({ key: m.key, label: m.label }, decode(data[m.key])));
  }
  const $ = (id) => document.getElementById(id);
  const selA = $("sel-a"), selB = $("sel-b"), exposure = $("exposure"), split = $("split");
  const zoom = $("zoom"), view = $("view"), crops = $("crops");
  for (const sel of [selA, selB]) {
    for (const im of images) {
      const o = document.createElement("option");
      o.value = im.key; o.textContent = im.label; sel.appendChild(o);
    }
  }
  // Default: the first method on the left, the reference on the right.
  if (images.length > 1) selA.value = images[1].key;
  if (images.length > 0) selB.value = images[0].key;
  const byKey = (k) => images.find((im) => im.key === k);
  const W = images.length ? images[0].w : 1, H = images.length ? images[0].h : 1;
  view.width = W; view.height = H;
  // Small renders are shown enlarged (pixelated) so they can be inspected.
  view.style.width = Math.max(W, Math.min(1024, W * Math.max(1, Math.floor(512 / W)))) + "px";
  const ctx = view.getContext("2d", { willReadFrequently: true });
  let crop = { x: Math.floor(W / 2), y: Math.floor(H / 2) };

  function scale() { return Math.pow(2, parseFloat(exposure.value)); }

  function draw() {
    $("exposure-value").textContent = parseFloat(exposure.value).toFixed(1);
    const a = byKey(selA.value), b = byKey(selB.value);
    if (!a || !b) return;
    const s = scale();
    const cut = Math.round(parseInt(split.value, 10) / 1000 * W);
    const img = ctx.createImageData(W, H);
    const d = img.data;
    for (let y = 0; y < H; y++) {
      for (let x = 0; x < W; x++) {
        const src = x < cut ? a : b;
        const i = y * W + x;
        d[4 * i] = tone(src.rgb[3 * i], s);
        d[4 * i + 1] = tone(src.rgb[3 * i + 1], s);
        d[4 * i + 2] = tone(src.rgb[3 * i + 2], s);
        d[4 * i + 3] = 255;
      }
    }
    ctx.putImageData(img, 0, 0);
    drawCrops();
  }

  function drawCrops() {
    const z = parseInt(zoom.value, 10);
    const size = Math.max(8, Math.floor(256 / z));
    const x0 = Math.max(0, Math.min(W - size, crop.x - (size >> 1)));
    const y0 = Math.max(0, Math.min(H - size, crop.y - (size >> 1)));
    const cw = Math.min(size, W), ch = Math.min(size, H);
    crops.textContent = "";
    const s = scale();
    for (const im of images) {
      const fig = document.createElement("figure");
      const c = document.createElement("canvas");
      c.width = cw; c.height = ch;
      c.style.width = cw * z + "px"; c.style.height = ch * z + "px";
      const cx = c.getContext("2d");
      const id = cx.createImageData(cw, ch);
      for (let y = 0; y < ch; y++) {
        for (let x = 0; x < cw; x++) {
          const i = (y0 + y) * W + (x0 + x), o = 4 * (y * cw + x);
          id.data[o] = tone(im.rgb[3 * i], s);
          id.data[o + 1] = tone(im.rgb[3 * i + 1], s);
          id.data[o + 2] = tone(im.rgb[3 * i + 2], s);
          id.data[o + 3] = 255;
        }
      }
      cx.putImageData(id, 0, 0);
      const cap = document.createElement("figcaption");
      cap.textContent = im.label;
      fig.appendChild(c); fig.appendChild(cap); crops.appendChild(fig);
    }
  }

  function eventPixel(e) {
    const r = view.getBoundingClientRect();
    return {
      x: Math.max(0, Math.min(W - 1, Math.floor((e.clientX - r.left) / r.width * W))),
      y: Math.max(0, Math.min(H - 1, Math.floor((e.clientY - r.top) / r.height * H))),
    };
  }
  let dragging = false;
  view.addEventListener("mousedown", (e) => { dragging = true; const p = eventPixel(e); crop = p; split.value = Math.round((p.x + 0.5) / W * 1000); draw(); });
  window.addEventListener("mouseup", () => { dragging = false; });
  view.addEventListener("mousemove", (e) => { if (dragging) { split.value = Math.round((eventPixel(e).x + 0.5) / W * 1000); draw(); } });
  function flip() { const t = selA.value; selA.value = selB.value; selB.value = t; draw(); }
  $("flip").addEventListener("click", flip);
  window.addEventListener("keydown", (e) => { if (e.key === "f") flip(); });
  for (const el of [selA, selB, exposure, split, zoom]) {
    el.addEventListener("input", draw);
    el.addEventListener("change", draw);
  }
  draw();

  // Self-test: through the controls' own events, the slider must show the left image entirely at one
  // end and the right image at the other, at a pixel where the two differ.
  function selftest() {
    const out = [];
    if (images.length < 2) out.push("fewer than two images");
    const a = images[1], b = images[0];
    if (a && b) {
      selA.value = a.key; selA.dispatchEvent(new Event("change"));
      selB.value = b.key; selB.dispatchEvent(new Event("change"));
      const s = scale();
      let px = -1;
      for (let i = 0; i < W * H && px < 0; i++) {
        for (let c = 0; c < 3; c++) if (tone(a.rgb[3 * i + c], s) !== tone(b.rgb[3 * i + c], s)) { px = i; break; }
      }
      if (px < 0) out.push("the two images look identical");
      else {
        const x = px % W, y = Math.floor(px / W);
        const shown = () => Array.from(ctx.getImageData(x, y, 1, 1).data.slice(0, 3));
        const expect = (im) => [0, 1, 2].map((c) => tone(im.rgb[3 * px + c], s));
        const same = (p, q) => p.every((v, i) => v === q[i]);
        split.value = "1000"; split.dispatchEvent(new Event("input"));
        if (!same(shown(), expect(a))) out.push("split at the right end does not show the left image at (" + x + "," + y + ")");
        split.value = "0"; split.dispatchEvent(new Event("input"));
        if (!same(shown(), expect(b))) out.push("split at the left end does not show the right image");
        $("flip").click();
        split.value = "1000"; split.dispatchEvent(new Event("input"));
        if (!same(shown(), expect(b))) out.push("flip does not swap the images");
        $("flip").click();
        split.value = "500"; split.dispatchEvent(new Event("input"));
      }
      if (crops.querySelectorAll("canvas").length !== images.length) out.push("crops missing");
    }
    for (const e of errors) out.push("page error: " + e);
    $("selftest").textContent = out.length ? "SELFTEST FAIL: " + out.join("; ") : "SELFTEST PASS (" + images.length + " images)";
  }
  if (location.hash === "#selftest") {
    // After every image and figure has loaded, so their load errors are counted too.
    window.addEventListener("load", selftest);
  }
})();
