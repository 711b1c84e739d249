// robodyn replay page: builds the meshcat scene from the embedded commands (the same
// msgpack messages a meshcat server would send), then shows the simulation time and the
// total energy in step with meshcat's animation clock. "#t=1.5" in the URL opens the
// page paused at t = 1.5 s of simulation time.
(function () {
  "use strict";
  var info = JSON.parse(document.getElementById("robodyn-info").textContent);
  var commands = JSON.parse(document.getElementById("robodyn-commands").textContent);
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

  function energyAt(tau) {
    var k = frameAt(tau);
    if (k + 1 >= info.tau.length) { return info.energy[k]; }
    var s = (tau - info.tau[k]) / (info.tau[k + 1] - info.tau[k]);
    s = Math.max(0, Math.min(1, s));
    return (1 - s) * info.energy[k] + s * info.energy[k + 1];
  }

  var overlay = document.getElementById("robodyn-overlay");
  var last = "";
  function update() {
    var tau = (info.animated && viewer.animator) ? viewer.animator.time : 0;
    var text = info.robot + "   t = " + (info.t0 + tau * info.speed).toFixed(3) + " s";
    if (info.energy.length) {
      text += "   E = " + energyAt(tau).toPrecision(6) + " J";
    }
    if (info.speed !== 1) {
      text += "   (x" + info.speed + ")";
    }
    if (info.animated) {
      text += "\nOpen Controls > Animations: play, pause, time slider";
    }
    if (text !== last) {
      overlay.textContent = text;
      last = text;
    }
    window.requestAnimationFrame(update);
  }

  function seekFromHash() {
    var match = /(?:^|[#&])t=([-+0-9.eE]+)/.exec(window.location.hash);
    if (!match || !info.animated) { return; }
    var tau = Math.max(0, (parseFloat(match[1]) - info.t0) / info.speed);
    var animator = viewer.animator;
    animator.play();
    animator.pause();
    animator.seek(tau);
    animator.display_progress(tau);
  }

  seekFromHash();
  window.addEventListener("hashchange", seekFromHash);
  update();
  document.body.setAttribute("data-robodyn", "ready");
})();
