// robodyn replay page: builds the meshcat scene from the embedded commands (the same
// msgpack messages a meshcat server would send), then shows the simulation time and the
// total energy in step with meshcat's animation clock, and draws the chart panel at the
// right of the 3D pane: one canvas per chart, a magenta cursor at the animation's time,
// and a click on a chart seeks the animation there. "#t=1.5" in the URL opens the page
// paused at t = 1.5 s of simulation time.
(function () {
  "use strict";
  var info = JSON.parse(document.getElementById("robodyn-info").textContent);
  var commands = JSON.parse(document.getElementById("robodyn-commands").textContent);
  var panelInfo = info.panel;
  var hasPanel = info.animated && panelInfo && panelInfo.charts.length > 0;
  if (hasPanel) {
    document.body.style.setProperty("--panel-width", panelInfo.width + "px");
    document.body.classList.add("with-panel");
  }
  var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  window.viewer = viewer;

  function decode(b64) {
    var text = atob(b64);
    var bytes = new Uint8Array(text.length);
    for (var i = 0; i < text.length; i++) {
      bytes[i] = text.charCodeAt(i);
    }
    return bytes;
  }
  commands.forEach(function (c) { viewer.handle_command_bytearray(decode(c)); });

  var duration = info.tau.length ? info.tau[info.tau.length - 1] : 0;

  // Index of the last rendered frame at or before playback time tau (binary search).
  function frameAt(tau) {
    var lo = 0, hi = info.tau.length - 1;
    if (tau <= info.tau[0]) { return 0; }
    if (tau >= info.tau[hi]) { return hi; }
    while (hi - lo > 1) {
      var mid = (lo + hi) >> 1;
      if (info.tau[mid] <= tau) { lo = mid; } else { hi = mid; }
    }
    return lo;
  }

  function energyAt(tau, energy) {
    energy = energy || info.energy;
    var k = frameAt(tau);
    if (k + 1 >= info.tau.length) { return energy[k]; }
    var s = (tau - info.tau[k]) / (info.tau[k + 1] - info.tau[k]);
    s = Math.max(0, Math.min(1, s));
    return (1 - s) * energy[k] + s * energy[k + 1];
  }

  function seek(tau) {
    var animator = viewer.animator;
    tau = Math.max(0, Math.min(duration, tau));
    animator.play();
    animator.pause();
    animator.seek(tau);
    animator.display_progress(tau);
  }

  function currentTau() {
    return (info.animated && viewer.animator) ? viewer.animator.time : 0;
  }

  // ------------------------------------------------------------------ the chart panel
  function fmt(x) {
    if (x === 0) { return "0"; }
    var a = Math.abs(x);
    return (a >= 1e4 || a < 1e-3) ? x.toExponential(2).replace(/\.?0+e/, "e") : String(parseFloat(x.toPrecision(3)));
  }

  function svgKey(color, dash) {
    var ns = "http://www.w3.org/2000/svg";
    var svg = document.createElementNS(ns, "svg");
    svg.setAttribute("width", "22");
    svg.setAttribute("height", "8");
    var line = document.createElementNS(ns, "line");
    line.setAttribute("x1", "0"); line.setAttribute("y1", "4");
    line.setAttribute("x2", "22"); line.setAttribute("y2", "4");
    line.setAttribute("stroke", color); line.setAttribute("stroke-width", "2.5");
    if (dash.length) { line.setAttribute("stroke-dasharray", dash.join(" ")); }
    svg.appendChild(line);
    return svg;
  }

  function addKey(parent, color, dash, text) {
    var key = document.createElement("span");
    key.className = "robodyn-key";
    key.appendChild(svgKey(color, dash));
    key.appendChild(document.createTextNode(text));
    parent.appendChild(key);
    return key;
  }

  // A legend entry of a curve is a switch: a click hides or shows that curve (every run's), and the
  // value axis fits what is left (a Panda's nine torques, a spring's couple beside small torques).
  function selectable(key, entry, label) {
    key.classList.add("robodyn-toggle");
    key.title = "click to hide or show " + label;
    key.addEventListener("click", function () {
      var hidden = !key.classList.contains("robodyn-off");
      key.classList.toggle("robodyn-off", hidden);
      entry.chart.series.forEach(function (s) { if (s.label === label) { s.hidden = hidden; } });
      drawChart(entry);
    });
  }

  var charts = [];
  var impactColor = (info.forces && info.forces.impactColor) || "#e69f00";
  function buildPanel() {
    var panel = document.getElementById("robodyn-panel");
    var runs = panelInfo.runs;
    if (runs.length > 1) {
      var header = document.createElement("div");
      header.className = "robodyn-runs";
      runs.forEach(function (run) { addKey(header, run.color, [], run.name); });
      panel.appendChild(header);
    }
    var headerHeight = runs.length > 1 ? 24 : 0;
    var each = Math.max(120, Math.floor((window.innerHeight - headerHeight) / panelInfo.charts.length));
    panelInfo.charts.forEach(function (chart) {
      var box = document.createElement("div");
      box.className = "robodyn-chart";
      box.setAttribute("data-chart", chart.key);
      var title = document.createElement("div");
      title.className = "robodyn-title";
      title.textContent = chart.title + (chart.unit ? " [" + chart.unit + "]" : "") + (chart.scale === "log" ? ", log scale" : "");
      box.appendChild(title);
      var legend = document.createElement("div");
      legend.className = "robodyn-legend";
      if ((chart.markers || []).length) { addKey(legend, impactColor, [], "impact on a stop (tick on the time axis)"); }
      var seen = {}, toggles = [];
      chart.series.forEach(function (s) {
        if (runs.length > 1) {
          if (seen[s.label]) { return; }
          seen[s.label] = true;
          toggles.push([addKey(legend, "#555", s.dash, s.label), s.label]);
        } else {
          toggles.push([addKey(legend, s.color, s.dash, s.label), s.label]);
        }
      });
      if (runs.length > 1 || chart.key === "regulated") {  // the grey dashed limits (several runs), the target
        var limitSeen = {};
        chart.limits.forEach(function (l) {
          if (!l.label || limitSeen[l.label]) { return; }
          limitSeen[l.label] = true;
          addKey(legend, l.color, panelInfo.limitDash, l.label);
        });
      }
      box.appendChild(legend);
      panel.appendChild(box);
      var height = Math.max(76, each - title.offsetHeight - legend.offsetHeight);
      var holder = document.createElement("div");
      holder.className = "robodyn-canvases";
      holder.style.height = height + "px";
      var plot = document.createElement("canvas");
      var cursor = document.createElement("canvas");
      [plot, cursor].forEach(function (c) {
        c.width = panelInfo.width - 1;
        c.height = height;
        holder.appendChild(c);
      });
      box.appendChild(holder);
      var entry = { chart: chart, box: box, plot: plot, cursor: cursor, width: plot.width, height: height, title: title, titleText: title.textContent };
      if (toggles.length > 1) { toggles.forEach(function (t) { selectable(t[0], entry, t[1]); }); }
      drawChart(entry);
      cursor.addEventListener("click", function (event) {
        var rect = cursor.getBoundingClientRect();
        seek(tauOfX(entry, event.clientX - rect.left));
      });
      charts.push(entry);
    });
  }

  function plotBox(entry) {
    var m = panelInfo.margins;
    return { left: m.left, right: entry.width - m.right, top: m.top, bottom: entry.height - m.bottom };
  }

  function xOfTau(entry, tau) {
    var b = plotBox(entry);
    return b.left + (duration > 0 ? tau / duration : 0) * (b.right - b.left);
  }

  function tauOfX(entry, x) {
    var b = plotBox(entry);
    return duration * (x - b.left) / (b.right - b.left);
  }

  // The value axis of a chart: frac(v) in [0, 1] from the bottom of the plot, and the ticks.
  // "log" (constraint drift, 1e-12 m and up): decades from the smallest positive value to the
  // largest, a zero drawn on the floor; "linear": the values' range, padded by 5 % each side.
  function logAxis(chart) {
    var lo = Infinity, hi = -Infinity;
    chart.series.forEach(function (s) {
      s.values.forEach(function (v) { if (v > 0) { lo = Math.min(lo, v); hi = Math.max(hi, v); } });
    });
    if (!(hi > 0)) { return null; }
    var a = Math.floor(Math.log10(lo)), b = Math.ceil(Math.log10(hi));
    if (b === a) { b = a + 1; }
    var step = Math.max(1, Math.ceil((b - a) / 3)), ticks = [];  // at most 4 labels
    for (var e = a; e <= b; e += step) { ticks.push({ value: Math.pow(10, e), label: "1e" + e }); }
    return {
      scale: "log",
      frac: function (v) { return (Math.log10(Math.max(v, Math.pow(10, a))) - a) / (b - a); },
      ticks: ticks
    };
  }

  // The smallest step of 1, 2 or 5 times a power of ten that gives at most maxTicks ticks over span:
  // tick labels read as round numbers, and never crowd a short chart.
  function niceStep(span, maxTicks) {
    var raw = span / Math.max(1, maxTicks - 1), power = Math.pow(10, Math.floor(Math.log10(raw))), m = raw / power;
    return power * (m <= 1 ? 1 : m <= 2 ? 2 : m <= 5 ? 5 : 10);
  }

  function linearAxis(chart, maxTicks) {
    var lo = Infinity, hi = -Infinity;
    chart.series.forEach(function (s) {
      if (s.hidden) { return; }
      s.values.forEach(function (v) { lo = Math.min(lo, v); hi = Math.max(hi, v); });
    });
    chart.limits.forEach(function (l) { lo = Math.min(lo, l.value); hi = Math.max(hi, l.value); });
    if (!(hi > lo)) { var c = isFinite(lo) ? lo : 0; var half = c === 0 ? 1 : Math.abs(c) * 0.1; lo = c - half; hi = c + half; }
    var pad = 0.05 * (hi - lo);
    lo -= pad; hi += pad;
    function frac(v) { return (v - lo) / (hi - lo); }
    var step, values, wanted = maxTicks;
    do {  // at least two ticks, so that the scale can be read (one "0" alone says nothing of the size)
      step = niceStep(hi - lo, wanted); values = [];
      for (var k = Math.ceil(lo / step); k * step <= hi + 1e-9 * step; k++) { values.push(k * step); }
      wanted += 1;
    } while (values.length < 2 && wanted < 12);
    // Ticks far from 1 (a ledger's residual of 1e-11 J, a drift of 1e5) share one power of ten,
    // written once beside the title ("x 1e-11"): the ticks read as short numbers, never "0 J" alone.
    var biggest = Math.max(Math.abs(lo), Math.abs(hi)), exponent = 0;
    if (biggest > 0 && (biggest < 1e-2 || biggest >= 1e4)) { exponent = Math.floor(Math.log10(step)); }
    var scaleBy = Math.pow(10, exponent);
    return {
      scale: "linear",
      exponent: exponent,
      frac: frac,
      ticks: values.map(function (v) {
        var r = Math.abs(v) < 1e-9 * step ? 0 : v;
        return { value: r, label: fmt(parseFloat((r / scaleBy).toPrecision(6))) };
      })
    };
  }

  function drawChart(entry) {
    var chart = entry.chart, ctx = entry.plot.getContext("2d"), b = plotBox(entry);
    var maxTicks = Math.max(2, Math.min(5, Math.floor((b.bottom - b.top) / 16)));  // a label per 16 px at most
    var axis = (chart.scale === "log" && logAxis(chart)) || linearAxis(chart, maxTicks);
    function y(v) { return b.bottom - axis.frac(v) * (b.bottom - b.top); }
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, entry.width, entry.height);
    ctx.strokeStyle = "#333"; ctx.lineWidth = 1; ctx.setLineDash([]);
    ctx.beginPath();
    ctx.moveTo(b.left, b.top); ctx.lineTo(b.left, b.bottom); ctx.lineTo(b.right, b.bottom);
    ctx.stroke();
    ctx.fillStyle = "#222"; ctx.font = "11px sans-serif";
    // value ticks, with the unit (listed on the chart's box for tests and screen readers)
    ctx.textAlign = "right"; ctx.textBaseline = "middle";
    var labels = [];
    axis.ticks.forEach(function (tick) {
      var text = (chart.tickUnit === false || axis.exponent) ? tick.label : tick.label + " " + chart.unit;
      labels.push(text);
      ctx.fillText(text, b.left - 4, y(tick.value));
      ctx.strokeStyle = "#e3e3e3"; ctx.beginPath(); ctx.moveTo(b.left + 1, y(tick.value)); ctx.lineTo(b.right, y(tick.value)); ctx.stroke();
    });
    // the shared power of ten goes in the title: "[J], ticks x 1e-11 J"
    entry.title.textContent = entry.titleText + (axis.exponent ? ", ticks \u00d7 1e" + axis.exponent + (chart.unit ? " " + chart.unit : "") : "");
    entry.box.setAttribute("data-exponent", String(axis.exponent || 0));
    entry.box.setAttribute("data-scale", axis.scale);
    entry.box.setAttribute("data-ticks", labels.join("|"));
    // time ticks, in simulation time
    ctx.textAlign = "center"; ctx.textBaseline = "top";
    [0, 0.5, 1].forEach(function (f) {
      var tau = f * duration;
      ctx.fillText(fmt(info.t0 + tau * info.speed) + " s", xOfTau(entry, tau), b.bottom + 3);
    });
    // limits, dashed
    chart.limits.forEach(function (l) {
      ctx.strokeStyle = l.color; ctx.lineWidth = chart.key === "regulated" ? 2 : 1; ctx.setLineDash(panelInfo.limitDash);
      ctx.beginPath(); ctx.moveTo(b.left, y(l.value)); ctx.lineTo(b.right, y(l.value)); ctx.stroke();
    });
    // events (impacts on the stops): short red ticks on the time axis
    (chart.markers || []).forEach(function (frame) {
      var k = Math.floor(frame), s = frame - k;
      var tau = k + 1 < info.tau.length ? (1 - s) * info.tau[k] + s * info.tau[k + 1] : info.tau[info.tau.length - 1];
      var x = xOfTau(entry, tau);
      ctx.strokeStyle = impactColor; ctx.lineWidth = 2; ctx.setLineDash([]);
      ctx.beginPath(); ctx.moveTo(x, b.bottom); ctx.lineTo(x, b.bottom - 8); ctx.stroke();
    });
    entry.box.setAttribute("data-markers", String((chart.markers || []).length));
    entry.box.setAttribute("data-limits", chart.limits.map(function (l) { return l.label + ":" + l.value + ":" + Math.round(y(l.value)); }).join("|"));
    // curves
    chart.series.forEach(function (s) {
      if (s.hidden) { return; }
      ctx.strokeStyle = s.color; ctx.lineWidth = 1.6; ctx.setLineDash(s.dash);
      ctx.beginPath();
      s.values.forEach(function (v, k) {
        var x = xOfTau(entry, info.tau[k]);
        if (k === 0) { ctx.moveTo(x, y(v)); } else { ctx.lineTo(x, y(v)); }
      });
      ctx.stroke();
    });
    ctx.setLineDash([]);
  }

  function drawCursors(tau) {
    charts.forEach(function (entry) {
      var ctx = entry.cursor.getContext("2d"), b = plotBox(entry), x = Math.round(xOfTau(entry, tau)) + 0.5;
      ctx.clearRect(0, 0, entry.width, entry.height);
      ctx.strokeStyle = panelInfo.cursor; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.moveTo(x, b.top); ctx.lineTo(x, b.bottom); ctx.stroke();
    });
    document.body.setAttribute("data-cursor-tau", String(tau));
  }

  // ------------------------------------------------------------------ the fading trace
  // Each run's line keeps only info.traceWindow seconds of playback up to the cursor, its
  // vertex colours fading from the run's colour (at the cursor) to white (at the window's
  // start); the dots (one per rendered frame) keep the same window. data-trace-ranges on the
  // body lists each line's drawn vertices as "first:count" (for tests).
  function sceneObject(path) {
    var node = viewer.scene_tree.find(path);
    var inner = node.children["<object>"];
    return (inner && inner.object && inner.object.geometry) ? inner.object : node.object;
  }
  var traces = (info.traces || []).map(function (tr) {
    var line = sceneObject(tr.line), dots = sceneObject(tr.dots);
    var colors = line.geometry.getAttribute("color");
    return {
      tau: tr.tau, line: line, dots: dots, colors: colors,
      base: colors ? Float32Array.from(colors.array) : null
    };
  });
  function firstAtOrAfter(times, t) {
    var lo = 0, hi = times.length;
    while (lo < hi) { var mid = (lo + hi) >> 1; if (times[mid] < t) { lo = mid + 1; } else { hi = mid; } }
    return lo;
  }
  // meshcat's background is a vertical gradient: a point of the trace fades to the background's
  // colour at its own height on the screen, so that old trace sinks into the sky behind it.
  var background = info.background || [[1, 1, 1], [1, 1, 1]];
  function backgroundAt(ndcY) {
    var s = Math.max(0, Math.min(1, (ndcY + 1) / 2));  // 0 at the bottom of the pane, 1 at the top
    return [0, 1, 2].map(function (c) { return background[1][c] + s * (background[0][c] - background[1][c]); });
  }
  function fadeTraces(tau) {
    if (info.traceWindow === null || info.traceWindow === undefined || !traces.length) { return; }
    var window_ = info.traceWindow, start = tau - window_, ranges = [];
    var THREE = MeshCat.THREE, camera = viewer.camera;
    viewer.scene_tree.object.updateMatrixWorld(true);  // the drawing's shift may not have been rendered yet
    camera.updateMatrixWorld(true);
    traces.forEach(function (tr) {
      var first = firstAtOrAfter(tr.tau, start), end = firstAtOrAfter(tr.tau, tau + 1e-9);
      var count = Math.max(0, end - first);
      tr.line.geometry.setDrawRange(first, count);
      if (tr.colors) {
        var position = tr.line.geometry.getAttribute("position").array, point = new THREE.Vector3();
        for (var i = first; i < end; i++) {
          var f = Math.max(0, Math.min(1, (tr.tau[i] - start) / window_));  // 0 at the window's start, 1 now
          point.set(position[3 * i], position[3 * i + 1], position[3 * i + 2]).applyMatrix4(tr.line.matrixWorld).project(camera);
          var back = backgroundAt(point.y);
          for (var c = 0; c < 3; c++) { tr.colors.array[3 * i + c] = back[c] + f * (tr.base[3 * i + c] - back[c]); }
        }
        tr.colors.needsUpdate = true;
      }
      var dotFirst = firstAtOrAfter(info.tau, start), dotEnd = firstAtOrAfter(info.tau, tau + 1e-9);
      tr.dots.geometry.setDrawRange(dotFirst, Math.max(0, dotEnd - dotFirst));
      ranges.push(first + ":" + count);
    });
    document.body.setAttribute("data-trace-ranges", ranges.join("|"));
  }

  // ------------------------------------------------------------------ labels over the 3D view
  // Texts on frames (a textbook figure's A, B, C) and joint angles (an arc from a dashed
  // reference ray, with its text), given in the model's world frame at each rendered frame:
  // interpolated at the animation's time, moved by the drawing's shift (the root's transform,
  // animated in follow mode) and projected through meshcat's camera onto the 3D pane, every
  // frame (the user may orbit the camera). data-labels on the body lists each text and its
  // pixel "text:x,y" (for tests).
  var marks = info.labels || { points: [], angles: [] };
  var labelSvg = document.getElementById("robodyn-labels");
  var hasLabels = marks.points.length + marks.angles.length > 0;
  var SVG_NS = "http://www.w3.org/2000/svg";
  function svgChild(tag, attrs) {
    var el = document.createElementNS(SVG_NS, tag);
    Object.keys(attrs).forEach(function (k) { el.setAttribute(k, attrs[k]); });
    labelSvg.appendChild(el);
    return el;
  }
  var drawn = { angles: [], points: [] };
  if (hasLabels) {
    marks.angles.forEach(function (a) {
      drawn.angles.push({
        mark: a,
        ray: svgChild("line", { stroke: "#333", "stroke-width": "1.5", "stroke-dasharray": "5 4" }),
        arc: svgChild("polyline", { fill: "none", stroke: "#111", "stroke-width": "2" }),
        text: svgChild("text", { "text-anchor": "middle", "dominant-baseline": "central" })
      });
      drawn.angles[drawn.angles.length - 1].text.textContent = a.text;
    });
    marks.points.forEach(function (p) {
      var dot = svgChild("circle", { r: "3.5", fill: "#111", stroke: "#fff", "stroke-width": "1.5" });
      var text = svgChild("text", { "text-anchor": "start", "dominant-baseline": "central" });
      text.textContent = p.text;
      drawn.points.push({ mark: p, dot: dot, text: text });
    });
  }
  // A point of a series (an array of [x, y, z], one per rendered frame, or {length, at(k)}) at time tau.
  function pointAt(series, tau) {
    var get = series.at && !Array.isArray(series) ? series.at : function (k) { return series[k]; };
    var k = frameAt(tau);
    if (k + 1 >= series.length || k + 1 >= info.tau.length) { return get(Math.min(k, series.length - 1)); }
    var s = Math.max(0, Math.min(1, (tau - info.tau[k]) / (info.tau[k + 1] - info.tau[k])));
    var a = get(k), b = get(k + 1);
    return [0, 1, 2].map(function (i) { return (1 - s) * a[i] + s * b[i]; });
  }
  function drawLabels(tau) {
    if (!hasLabels) { return; }
    var THREE = MeshCat.THREE, camera = viewer.camera, node = viewer.scene_tree.find(info.root);
    var pane = document.getElementById("meshcat-pane").getBoundingClientRect();
    node.object.updateMatrixWorld(true);
    camera.updateMatrixWorld(true);
    function screen(p) {
      var v = new THREE.Vector3(p[0], p[1], p[2]).applyMatrix4(node.object.matrixWorld).project(camera);
      return [(v.x + 1) / 2 * pane.width, (1 - v.y) / 2 * pane.height];
    }
    var listed = [];
    drawn.angles.forEach(function (d) {
      var arc = d.mark.arc[0].map(function (_, n) {
        return screen(pointAt({ length: d.mark.arc.length, at: function (k) { return d.mark.arc[k][n]; } }, tau));
      });
      var o = screen(pointAt(d.mark.ray.map(function (r) { return r[0]; }), tau));
      var e = screen(pointAt(d.mark.ray.map(function (r) { return r[1]; }), tau));
      d.ray.setAttribute("x1", o[0]); d.ray.setAttribute("y1", o[1]);
      d.ray.setAttribute("x2", e[0]); d.ray.setAttribute("y2", e[1]);
      d.arc.setAttribute("points", arc.map(function (p) { return p[0].toFixed(1) + "," + p[1].toFixed(1); }).join(" "));
      var at = screen(pointAt(d.mark.at, tau));
      d.text.setAttribute("x", at[0]); d.text.setAttribute("y", at[1]);
      listed.push(d.mark.text + ":" + Math.round(at[0]) + "," + Math.round(at[1]));
    });
    drawn.points.forEach(function (d) {
      var p = screen(pointAt(d.mark.xyz, tau));
      d.dot.setAttribute("cx", p[0]); d.dot.setAttribute("cy", p[1]);
      d.text.setAttribute("x", p[0] + 8); d.text.setAttribute("y", p[1] - 12);
      listed.push(d.mark.text + ":" + Math.round(p[0]) + "," + Math.round(p[1]));
    });
    document.body.setAttribute("data-labels", listed.join("|"));
  }

  // ------------------------------------------------------------------ forces, impacts, mode, in 3D
  // Each applied force or torque as an arrow where it acts (a straight one along a prismatic
  // joint, a curved one about a revolute joint; its value written at its head), each hit on a
  // stop flashed on its joint for forces.flash seconds, and the controller's mode written above
  // the robot. data-arrows on the body lists "joint:x,y" of each drawn arrow's head, data-impacts
  // the joints flashing now, data-mode the mode's text (for tests).
  var forces = info.forces || { arrows: [], impacts: [], mode: null };
  var hasForces = forces.arrows.length + forces.impacts.length > 0 || !!forces.mode;
  var textStyle = "font: bold 15px sans-serif; stroke: #fff; stroke-width: 3px; paint-order: stroke;";
  var drawnForces = { arrows: [], impacts: [], mode: null };
  if (hasForces) {
    forces.arrows.forEach(function (a) {
      drawnForces.arrows.push({
        mark: a,
        halo: svgChild("polyline", { fill: "none", stroke: "#fff", "stroke-width": "7", "stroke-linecap": "round" }),
        line: svgChild("polyline", { fill: "none", stroke: a.color, "stroke-width": "3.5", "stroke-linecap": "round" }),
        head: svgChild("polygon", { fill: a.color, stroke: "#fff", "stroke-width": "1.5" }),
        text: svgChild("text", { style: textStyle + "fill: " + a.color, "dominant-baseline": "central" })
      });
    });
    forces.impacts.forEach(function (m) {
      var k = Math.floor(m.frame), s = m.frame - k;
      var at = k + 1 < info.tau.length ? (1 - s) * info.tau[k] + s * info.tau[k + 1] : info.tau[info.tau.length - 1];
      drawnForces.impacts.push({
        mark: m, tau: at,
        ring: svgChild("circle", { r: "16", fill: "none", stroke: forces.impactColor, "stroke-width": "5" }),
        text: svgChild("text", { style: textStyle + "fill: #111", "dominant-baseline": "central" })  // the ring is orange
      });
    });
    if (forces.mode) {
      drawnForces.mode = svgChild("text", { style: textStyle + "font-size: 17px; fill: " + forces.mode.color, "text-anchor": "middle" });
    }
  }
  function projector() {
    var THREE = MeshCat.THREE, camera = viewer.camera, node = viewer.scene_tree.find(info.root);
    var pane = document.getElementById("meshcat-pane").getBoundingClientRect();
    viewer.scene_tree.object.updateMatrixWorld(true);
    camera.updateMatrixWorld(true);
    return function (p) {
      var v = new THREE.Vector3(p[0], p[1], p[2]).applyMatrix4(node.object.matrixWorld).project(camera);
      return [(v.x + 1) / 2 * pane.width, (1 - v.y) / 2 * pane.height];
    };
  }
  function show(el, on) { el.setAttribute("visibility", on ? "visible" : "hidden"); }
  function drawForces(tau) {
    if (!hasForces) { return; }
    var screen = projector(), heads = [], flashing = [];
    drawnForces.arrows.forEach(function (d) {
      var a = d.mark, value = energyAt(tau, a.values);
      var pts = a.points[0].map(function (_, n) {
        return screen(pointAt({ length: a.points.length, at: function (k) { return a.points[k][n]; } }, tau));
      });
      var tip = pts[pts.length - 1], before = pts[pts.length - 2];
      var dx = tip[0] - before[0], dy = tip[1] - before[1], len = Math.sqrt(dx * dx + dy * dy);
      var spread = Math.abs(tip[0] - pts[0][0]) + Math.abs(tip[1] - pts[0][1]);
      var visible = len > 0 && (a.kind === "torque" || spread > 3);
      [d.halo, d.line, d.head, d.text].forEach(function (el) { show(el, visible); });
      if (!visible) { return; }
      dx /= len; dy /= len;
      var polyline = pts.map(function (p) { return p[0].toFixed(1) + "," + p[1].toFixed(1); }).join(" ");
      d.halo.setAttribute("points", polyline); d.line.setAttribute("points", polyline);
      var h = 13, w = 7;
      d.head.setAttribute("points", [
        [tip[0] + dx * h, tip[1] + dy * h],
        [tip[0] - dy * w, tip[1] + dx * w],
        [tip[0] + dy * w, tip[1] - dx * w]
      ].map(function (p) { return p[0].toFixed(1) + "," + p[1].toFixed(1); }).join(" "));
      d.text.setAttribute("x", tip[0] + dx * 18 + 4); d.text.setAttribute("y", tip[1] + dy * 18);
      d.text.textContent = a.symbol + " = " + value.toPrecision(3) + " " + a.unit;
      heads.push(a.joint + ":" + Math.round(tip[0] + dx * h) + "," + Math.round(tip[1] + dy * h));
    });
    var stacked = 0;  // the texts of simultaneous hits are stacked in the pane's lower left, never on each other
    var pane = document.getElementById("meshcat-pane").getBoundingClientRect();
    drawnForces.impacts.forEach(function (d) {
      var on = tau >= d.tau && tau - d.tau < forces.flash;
      show(d.ring, on); show(d.text, on);
      if (!on) { return; }
      var p = screen(d.mark.xyz);
      d.ring.setAttribute("cx", p[0]); d.ring.setAttribute("cy", p[1]);
      d.text.setAttribute("x", 12); d.text.setAttribute("y", pane.height - 20 - 20 * stacked);
      stacked += 1;
      d.text.textContent = "stop hit (orange ring): " + d.mark.joint + ", W_limits " + fmt(d.mark.energy) + " J";
      flashing.push(d.mark.joint + ":" + Math.round(p[0]) + "," + Math.round(p[1]));
    });
    if (drawnForces.mode) {
      var k = frameAt(tau), at = screen(pointAt(forces.mode.xyz, tau));
      drawnForces.mode.setAttribute("x", at[0]); drawnForces.mode.setAttribute("y", at[1]);
      drawnForces.mode.textContent = "mode: " + forces.mode.names[forces.mode.values[k]];
      document.body.setAttribute("data-mode", drawnForces.mode.textContent);
    }
    document.body.setAttribute("data-arrows", heads.join("|"));
    document.body.setAttribute("data-impacts", flashing.join("|"));
  }

  // ------------------------------------------------------------------ the overlay, every frame
  var overlay = document.getElementById("robodyn-overlay");
  var last = "", lastTau = null, lastView = "";
  function update() {
    var tau = currentTau();
    var text = info.robot + "   t = " + (info.t0 + tau * info.speed).toFixed(3) + " s";
    var runEnergies = info.runEnergies || [];
    if (info.energy.length && runEnergies.length < 2) {
      text += "   E = " + energyAt(tau).toPrecision(6) + " J";
      if (panelInfo && panelInfo.runs.length > 1) { text += " (" + panelInfo.runs[0].name + ")"; }
    }
    // several runs: one line per run, "E = ... J  name", in the run's colour
    var perRun = runEnergies.map(function (r) { return "E = " + energyAt(tau, r.energy).toPrecision(6) + " J  " + r.name; });
    if (info.speed !== 1) {
      text += "   (x" + info.speed + ")";
    }
    (info.notes || []).forEach(function (note) { text += "\n" + note; });
    if (info.animated) {
      text += "\nOpen Controls > Animations: play, pause, time slider";
      if (hasPanel) { text += "\nClick a chart to seek; camera: " + info.camera; }
    }
    var whole = text + "\n" + perRun.join("\n");
    if (whole !== last) {
      overlay.textContent = "";
      var lines = text.split("\n");
      overlay.appendChild(document.createTextNode(lines[0]));
      perRun.forEach(function (line, r) {
        var span = document.createElement("span");
        span.className = "robodyn-run-energy";
        span.style.color = runEnergies[r].color;
        span.style.fontWeight = "bold";
        span.textContent = line;
        overlay.appendChild(document.createTextNode("\n"));
        overlay.appendChild(span);
      });
      if (lines.length > 1) { overlay.appendChild(document.createTextNode("\n" + lines.slice(1).join("\n"))); }
      last = whole;
    }
    drawLabels(tau);  // every frame: the camera may have been orbited
    drawForces(tau);
    // the fade depends on where each point is on the screen: again when the camera moves or is resized
    var view = viewer.camera.matrixWorld.elements.join(",") + viewer.camera.projectionMatrix.elements.join(",");
    if (tau !== lastTau || view !== lastView) {
      if (hasPanel && tau !== lastTau) { drawCursors(tau); }
      fadeTraces(tau);
      lastTau = tau;
      lastView = view;
    }
    window.requestAnimationFrame(update);
  }

  function seekFromHash() {
    var match = /(?:^|[#&])t=([-+0-9.eE]+)/.exec(window.location.hash);
    if (!match || !info.animated) { return; }
    seek((parseFloat(match[1]) - info.t0) / info.speed);
  }

  if (hasPanel) { buildPanel(); }
  seekFromHash();
  window.addEventListener("hashchange", seekFromHash);
  update();
  document.body.setAttribute("data-robodyn", "ready");
})();
