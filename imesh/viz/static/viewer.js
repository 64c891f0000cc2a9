/* imesh viewer: plays back a scene built by imesh.viz.scene.build_robots_scene with three.js.
 * The scene comes inline (script#imesh-scene, the self-contained page) or from scene.json (the
 * local server). window.imeshViewer exposes setFrame/play/pause for tests and scripts.
 * S.robots holds one robot, or the two of a pair, each drawn where its motion puts it (one
 * world), with its own markers, source, floor overlays, self-collisions and limits; S.models
 * holds the meshes of each robot model once; S.props the scene's static props (translucent);
 * S.pair the pair's figures and the robots' distance per frame.
 * With a DART check (R.simulation) the simulated robot is drawn as a blue-tinted translucent
 * copy beside the reference (S.beside_m to its right, or overlaid); frames after its fall or
 * its end hold the last simulated pose (tinted red after a fall); "s" or the checkbox
 * shows/hides it. */
(function () {
  "use strict";
  var Z_UP = new THREE.Vector3(0, 0, 1);

  function decode(e) {
    var bin = atob(e.b64), n = bin.length, buf = new Uint8Array(n);
    for (var i = 0; i < n; i++) buf[i] = bin.charCodeAt(i);
    var T = {float32: Float32Array, uint32: Uint32Array, uint16: Uint16Array, uint8: Uint8Array};
    return new T[e.dtype](buf.buffer);
  }

  function loadScene() {
    var el = document.getElementById("imesh-scene");
    if (el && el.textContent.trim()) return Promise.resolve(JSON.parse(el.textContent));
    return fetch("scene.json").then(function (r) {
      if (!r.ok) throw new Error("scene.json: HTTP " + r.status);
      return r.json();
    });
  }

  function OrbitControl(camera, dom, target, radius) {
    // Z-up orbit at radius [m] from target: left drag rotates, right drag (or shift) pans,
    // wheel zooms.
    var self = this, sph = {r: radius, th: -0.55, ph: 1.22}, drag = null;
    this.target = target;
    this.update = function () {
      var s = Math.sin(sph.ph);
      camera.position.set(self.target.x + sph.r * s * Math.cos(sph.th),
                          self.target.y + sph.r * s * Math.sin(sph.th),
                          self.target.z + sph.r * Math.cos(sph.ph));
      camera.up.copy(Z_UP);
      camera.lookAt(self.target);
    };
    dom.addEventListener("contextmenu", function (ev) { ev.preventDefault(); });
    dom.addEventListener("pointerdown", function (ev) {
      drag = {x: ev.clientX, y: ev.clientY, pan: ev.button === 2 || ev.shiftKey};
      dom.setPointerCapture(ev.pointerId);
    });
    dom.addEventListener("pointerup", function () { drag = null; });
    dom.addEventListener("pointermove", function (ev) {
      if (!drag) return;
      var dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
      drag.x = ev.clientX; drag.y = ev.clientY;
      if (drag.pan) {
        var right = new THREE.Vector3().setFromMatrixColumn(camera.matrix, 0);
        var up = new THREE.Vector3().setFromMatrixColumn(camera.matrix, 1);
        var k = sph.r * 0.0015;
        self.target.addScaledVector(right, -dx * k).addScaledVector(up, dy * k);
      } else {
        sph.th -= dx * 0.008;
        sph.ph = Math.min(Math.max(sph.ph - dy * 0.008, 0.05), Math.PI - 0.05);
      }
      self.update();
    });
    dom.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      sph.r = Math.min(Math.max(sph.r * Math.exp(ev.deltaY * 0.001), 0.3), 40);
      self.update();
    }, {passive: false});
  }

  function lineSegments(maxSegments, color, opacity) {
    var g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(maxSegments * 6), 3));
    g.setDrawRange(0, 0);
    var m = new THREE.LineBasicMaterial({color: color, transparent: opacity < 1,
                                         opacity: opacity});
    var l = new THREE.LineSegments(g, m);
    l.frustumCulled = false;
    return l;
  }

  function markerSet(entry, color, scene3) {
    var names = entry.names, M = names.length;
    var pos = decode(entry.positions);
    var group = new THREE.Group();
    var sphere = new THREE.SphereGeometry(0.022, 12, 8);
    var mat = new THREE.MeshLambertMaterial({color: color});
    var balls = new THREE.InstancedMesh(sphere, mat, M);
    balls.frustumCulled = false;
    group.add(balls);
    var bones = lineSegments(entry.bones.length, color, 1.0);
    group.add(bones);
    scene3.add(group);
    var tmp = new THREE.Matrix4();
    return {
      group: group, pos: pos, M: M, offset: new THREE.Vector3(),
      set: function (t) {
        var o = this.offset, b = t * M * 3;
        for (var j = 0; j < M; j++) {
          tmp.makeTranslation(pos[b + 3 * j] + o.x, pos[b + 3 * j + 1] + o.y,
                              pos[b + 3 * j + 2] + o.z);
          balls.setMatrixAt(j, tmp);
        }
        balls.instanceMatrix.needsUpdate = true;
        var arr = bones.geometry.attributes.position.array;
        entry.bones.forEach(function (bn, k) {
          for (var e = 0; e < 2; e++) for (var c = 0; c < 3; c++)
            arr[6 * k + 3 * e + c] = pos[b + 3 * bn[e] + c] + [o.x, o.y, o.z][c];
        });
        bones.geometry.attributes.position.needsUpdate = true;
        bones.geometry.setDrawRange(0, 2 * entry.bones.length);
      }
    };
  }

  var SIM_TINT = new THREE.Color(0.23, 0.51, 0.96), FALL_TINT = new THREE.Color(0.85, 0.2, 0.2);
  // the adapted markers and the human source of robot 0, 1, ... (a pair: a, b)
  var MARKER_COLORS = [0x1a5af2, 0x0f9f8f], SOURCE_COLORS = [0x8c33bf, 0xd0407a];
  var RED = new THREE.Color(0.95, 0.1, 0.1);

  function simulationCopy(E, fps, T, linkGroups, scene3) {
    // the simulated robot: the reference's meshes (shared geometry) in tinted translucent
    // materials; after a fall it holds where it lay, tinted red
    var L = linkGroups.length;
    var groups = linkGroups.map(function () { var g = new THREE.Group(); scene3.add(g); return g; });
    var mats = [];
    linkGroups.forEach(function (g, l) {
      g.children.forEach(function (mesh) {
        var base = mesh.material.userData.base;
        var mat = new THREE.MeshPhongMaterial({color: base.clone().lerp(SIM_TINT, 0.65),
                                               shininess: 30, transparent: true, opacity: 0.6});
        mat.userData.tint = mat.color.clone();
        mat.userData.fallen = base.clone().lerp(FALL_TINT, 0.7);
        mats.push(mat);
        groups[l].add(new THREE.Mesh(mesh.geometry, mat));
      });
    });
    return {
      entry: E, groups: groups, mats: mats, L: L, poses: decode(E.link_poses),
      simulated: decode(E.simulated),
      kpErr: E.keypoint_error_mm ? decode(E.keypoint_error_mm) : null,
      offset: new THREE.Vector3(),
      fallFrame: E.fell ? Math.min(Math.round(E.survived_s * fps), T - 1) : -1,
      set: function (t, visible) {
        var P = this.poses, o = this.offset, down = !this.simulated[t] && this.entry.fell;
        for (var l = 0; l < L; l++) {
          var b = (t * L + l) * 7, g = groups[l];
          g.visible = visible;
          g.position.set(P[b] + o.x, P[b + 1] + o.y, P[b + 2] + o.z);
          g.quaternion.set(P[b + 3], P[b + 4], P[b + 5], P[b + 6]);
        }
        mats.forEach(function (m) { m.color.copy(down ? m.userData.fallen : m.userData.tint); });
      },
      line: function (t) {
        // the info line of frame t
        var E2 = this.entry, name = "DART simulation (" + E2.controller + ")";
        if (!this.simulated[t]) {
          return name + (E2.fell ? ": FELL at " + E2.survived_s.toFixed(2) +
                                   " s; showing where it lay" : ": ended, last pose held");
        }
        var e = this.kpErr ? this.kpErr[t] : NaN;
        return name + (isFinite(e) ? ": key points " + e.toFixed(0) + " mm from the reference"
                                   : "");
      },
      banner: function () {
        var E2 = this.entry, dur = E2.duration_s.toFixed(2);
        var kp = E2.keypoint_rms_mm === null ? "" : "; key points " +
          E2.keypoint_rms_mm.toFixed(0) + " mm RMS, " + E2.keypoint_max_mm.toFixed(0) + " mm max";
        return "DART check (" + E2.controller + "): " + (E2.fell ? "FELL at " +
          E2.survived_s.toFixed(2) + " s of " + dur + " s (" + E2.fall_reason + ")"
          : "stood through the " + dur + " s") + kp;
      }
    };
  }

  function modelGeometries(model) {
    // the meshes of a robot model, decoded once for every robot of that model
    if (!model.geometries) {
      model.geometries = model.meshes.map(function (m) {
        var g = new THREE.BufferGeometry();
        g.setAttribute("position", new THREE.BufferAttribute(decode(m.vertices), 3));
        g.setIndex(new THREE.BufferAttribute(decode(m.faces), 1));
        g.computeVertexNormals();
        return {link: m.link, geometry: g,
                color: new THREE.Color(m.color[0], m.color[1], m.color[2])};
      });
    }
    return model.geometries;
  }

  function robotView(S, R, index, scene3) {
    // one robot of the scene (S.robots[index]) with its own overlays: meshes, markers, human
    // source, interaction mesh, soles, support polygon, ZMP, self-collisions, limits, DART
    var T = S.frames, model = S.models[R.model], L = model.links.length;
    var poses = decode(R.link_poses), root = Math.max(model.links.indexOf(model.root_link), 0);
    var linkGroups = model.links.map(function () {
      var g = new THREE.Group(); scene3.add(g); return g;
    });
    var linkMats = model.links.map(function () { return []; });
    modelGeometries(model).forEach(function (m) {
      var mat = new THREE.MeshPhongMaterial({color: m.color.clone(), shininess: 30});
      mat.userData.base = m.color;
      linkGroups[m.link].add(new THREE.Mesh(m.geometry, mat));
      linkMats[m.link].push(mat);
    });
    var sim = R.simulation ? simulationCopy(R.simulation, S.fps, T, linkGroups, scene3) : null;
    var human = R.markers ? markerSet(R.markers, MARKER_COLORS[index % 2], scene3) : null;
    var source = R.source ? markerSet(R.source, SOURCE_COLORS[index % 2], scene3) : null;
    var edgesArr = R.mesh_edges ? decode(R.mesh_edges) : null;
    var E = R.mesh_edges ? R.mesh_edges.shape[1] : 0;
    var edgeLines = lineSegments(Math.max(E, 1), 0x3a7bd5, 0.35);
    scene3.add(edgeLines);

    // floor overlays
    var soles = decode(R.soles), support = decode(R.support);
    var polys = decode(R.polygons), polySizes = decode(R.polygon_sizes);
    var PW = R.polygons.shape[1];
    var zmp = decode(R.zmp), zdes = decode(R.zmp_desired), zin = decode(R.zmp_inside);
    var soleLines = lineSegments(8, 0x333333, 1.0);
    scene3.add(soleLines);
    var polyLine = lineSegments(PW, 0x1aa64d, 1.0);
    scene3.add(polyLine);
    var polyFillGeo = new THREE.BufferGeometry();
    polyFillGeo.setAttribute("position",
                             new THREE.BufferAttribute(new Float32Array(PW * 9), 3));
    var polyFill = new THREE.Mesh(polyFillGeo, new THREE.MeshBasicMaterial(
      {color: 0x1aa64d, transparent: true, opacity: 0.25, side: THREE.DoubleSide,
       depthWrite: false}));
    polyFill.frustumCulled = false;
    scene3.add(polyFill);
    function disc(color) {
      var d = new THREE.Mesh(new THREE.CylinderGeometry(0.025, 0.025, 0.004, 20),
                             new THREE.MeshBasicMaterial({color: color}));
      d.rotation.x = Math.PI / 2;
      scene3.add(d);
      return d;
    }
    var zmpDot = disc(0xd91a1a), desDot = disc(0x1a73e6);
    function path(arr, color) {
      var g = new THREE.BufferGeometry(), p = new Float32Array(T * 3);
      for (var t = 0; t < T; t++) { p[3 * t] = arr[2 * t]; p[3 * t + 1] = arr[2 * t + 1];
                                    p[3 * t + 2] = 0.002; }
      g.setAttribute("position", new THREE.BufferAttribute(p, 3));
      var l = new THREE.Line(g, new THREE.LineBasicMaterial({color: color, transparent: true,
                                                              opacity: 0.5}));
      scene3.add(l);
      return l;
    }
    var zmpPath = path(zmp, 0xd91a1a), desPath = path(zdes, 0x1a73e6);
    // the ZMP, its target and the support polygon stay visible through the feet
    [zmpDot, desDot, polyLine, soleLines].forEach(function (o) {
      o.material.depthTest = false;
      o.renderOrder = 10;
    });
    zmpDot.renderOrder = 12;
    var prefix = S.robots.length > 1 ? R.label + ": " : "";
    var bodies = model.collision_bodies || [];

    return {
      entry: R, model: model, sim: sim, human: human, source: source, groups: linkGroups,
      root: function (t) {
        var b = (t * L + root) * 7;
        return [poses[b], poses[b + 1], poses[b + 2]];
      },
      set: function (t, opts, beside) {
        // draw frame t; returns the robot's info lines and whether one is a warning
        var hits = {}, coll = R.collisions[t] || [];
        coll.forEach(function (c) {  // [body a, body b, depth mm]: paint both bodies' links
          [c[0], c[1]].forEach(function (b) {
            ((bodies[b] || {}).links || []).forEach(function (l) { hits[l] = 1; });
          });
        });
        for (var l = 0; l < L; l++) {
          var b = (t * L + l) * 7, g = linkGroups[l];
          g.position.set(poses[b], poses[b + 1], poses[b + 2]);
          g.quaternion.set(poses[b + 3], poses[b + 4], poses[b + 5], poses[b + 6]);
          linkMats[l].forEach(function (m) { m.color.copy(hits[l] ? RED : m.userData.base); });
        }
        var side = opts.beside.checked;
        if (human) {
          human.group.visible = opts.human.checked;
          human.offset.set(0, side ? beside : 0, 0);
          human.set(t);
        }
        if (source) {
          source.group.visible = opts.source.checked;
          source.offset.set(0, side ? -beside : beside, 0);
          source.set(t);
        }
        if (sim) {
          // beside: on the robot's right (1 m; 2 m when the human source takes that side)
          sim.offset.set(0, opts["sim-over"].checked ? 0 : (side && source ? -2 * beside
                                                                            : -beside), 0);
          sim.set(t, opts.sim.checked);
        }
        edgeLines.visible = !!(human && opts.edges.checked);
        if (edgesArr) {
          var hp = human.pos, M = human.M, arr = edgeLines.geometry.attributes.position.array;
          var n = 0, o = human.offset;
          for (var e = 0; e < E; e++) {
            var a = edgesArr[(t * E + e) * 2], c2 = edgesArr[(t * E + e) * 2 + 1];
            if (a === 65535) break;
            [a, c2].forEach(function (j) {
              arr[3 * n] = hp[(t * M + j) * 3] + o.x;
              arr[3 * n + 1] = hp[(t * M + j) * 3 + 1] + o.y;
              arr[3 * n + 2] = hp[(t * M + j) * 3 + 2] + o.z; n++;
            });
          }
          edgeLines.geometry.attributes.position.needsUpdate = true;
          edgeLines.geometry.setDrawRange(0, n);
        }
        var floorOn = opts.floor.checked;
        [soleLines, polyLine, polyFill, zmpDot, desDot, zmpPath, desPath].forEach(function (o2) {
          o2.visible = floorOn;
        });
        var sa = soleLines.geometry.attributes.position.array, k = 0;
        for (var s = 0; s < 2; s++) for (var i = 0; i < 4; i++) for (var e2 = 0; e2 < 2; e2++) {
          var ci = (((t * 2 + s) * 4) + (i + e2) % 4) * 3;
          sa[k++] = soles[ci]; sa[k++] = soles[ci + 1]; sa[k++] = Math.max(soles[ci + 2], 0.003);
        }
        soleLines.material.color.set(support[2 * t] || support[2 * t + 1] ? 0x222222 : 0x888888);
        soleLines.geometry.attributes.position.needsUpdate = true;
        soleLines.geometry.setDrawRange(0, 16);
        var ns = polySizes[t], pa = polyLine.geometry.attributes.position.array;
        var fa = polyFillGeo.attributes.position.array;
        var cx = 0, cy = 0;
        for (var v = 0; v < ns; v++) { cx += polys[(t * PW + v) * 2] / ns;
                                       cy += polys[(t * PW + v) * 2 + 1] / ns; }
        for (v = 0; v < ns; v++) {
          var p0 = (t * PW + v) * 2, p1 = (t * PW + (v + 1) % ns) * 2;
          pa.set([polys[p0], polys[p0 + 1], 0.003, polys[p1], polys[p1 + 1], 0.003], 6 * v);
          fa.set([cx, cy, 0.001, polys[p0], polys[p0 + 1], 0.001, polys[p1], polys[p1 + 1],
                  0.001], 9 * v);
        }
        polyLine.geometry.attributes.position.needsUpdate = true;
        polyLine.geometry.setDrawRange(0, 2 * ns);
        polyFillGeo.attributes.position.needsUpdate = true;
        polyFillGeo.setDrawRange(0, 3 * ns);
        zmpDot.position.set(zmp[2 * t], zmp[2 * t + 1], 0.004);
        desDot.position.set(zdes[2 * t], zdes[2 * t + 1], 0.003);
        zmpDot.visible = floorOn && ns > 0;

        var lim = R.limits[t] || [], lines = [];
        lines.push(prefix + (ns ? "support: " + ["left", "right"].filter(function (_, q) {
          return support[2 * t + q]; }).join(" + ") + (zin[t] ? "" : "  ZMP OUTSIDE")
          : "flight"));
        if (coll.length) lines.push(prefix + "self-collision: " + coll.map(function (c) {
          return bodies[c[0]].name + "-" + bodies[c[1]].name + " " + c[2] + " mm"; }).join(", "));
        if (lim.length) lines.push(prefix + "limits exceeded: " + lim.join(", "));
        var fallen = sim && sim.entry.fell && !sim.simulated[t];
        if (sim && opts.sim.checked) lines.push(prefix + sim.line(t));
        return {lines: lines,
                warn: !!(coll.length || lim.length || (fallen && opts.sim.checked))};
      }
    };
  }

  function propMeshes(S, scene3) {
    // the scene's static props (boxes, steps) as translucent meshes with their edges
    var group = new THREE.Group();
    (S.props || []).forEach(function (p) {
      var g = new THREE.BufferGeometry();
      g.setAttribute("position", new THREE.BufferAttribute(decode(p.vertices), 3));
      g.setIndex(new THREE.BufferAttribute(decode(p.faces), 1));
      g.computeVertexNormals();
      var mesh = new THREE.Mesh(g, new THREE.MeshPhongMaterial(
        {color: 0xc8a165, transparent: true, opacity: 0.45, side: THREE.DoubleSide,
         depthWrite: false}));
      mesh.name = p.name;
      group.add(mesh);
      group.add(new THREE.LineSegments(new THREE.EdgesGeometry(g, 20),
                                       new THREE.LineBasicMaterial({color: 0x7a5a2a})));
    });
    scene3.add(group);
    return group;
  }

  function pairLines(P, t) {
    // the pair's figures (OUT.pair.json) and the robots' distance at frame t
    if (!P) return {lines: [], warn: false};
    var m = P.metrics, lines = [], warn = false;
    function num(v, d) { return v === null || v === undefined ? "n/a" : (+v).toFixed(d); }
    lines.push("pair: hands held " + (m.hold_frames || 0) + " samples, " +
               num(m.hold_error_mean_mm, 0) + " mm mean / " + num(m.hold_error_max_mm, 0) +
               " mm max off; robots into each other " + num(m.robot_penetration_mm, 1) +
               " mm (" + (m.penetration_frames || 0) + " frames); close pairs " +
               num(m.inter_close_pair_error, 3));
    if (P.distanceMm) {
      var d = P.distanceMm[t], held = P.heldArr && P.heldArr[t] ? "  (hands held)" : "";
      if (!isFinite(d)) lines.push("robots: apart" + held);
      else if (d >= 0) lines.push("robots: " + d.toFixed(0) + " mm apart" + held);
      else {
        lines.push("robots: " + (-d).toFixed(0) + " mm into each other" + held);
        warn = -d > 5;
      }
    }
    return {lines: lines, warn: warn};
  }

  function build(S) {
    var T = S.frames, fps = S.fps, beside = S.beside_m || 1.0;
    var host = document.getElementById("view");
    var renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setClearColor(0xf4f6f8);
    host.appendChild(renderer.domElement);
    var scene3 = new THREE.Scene();
    var camera = new THREE.PerspectiveCamera(40, 1, 0.02, 100);
    scene3.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 0.9));
    var sun = new THREE.DirectionalLight(0xffffff, 0.7);
    sun.position.set(2, -3, 5);
    scene3.add(sun);
    (function grid() {  // 0.5 m floor grid on z = 0, 1 m lines darker
      var fine = [], bold = [];
      for (var i = -40; i <= 40; i++) {
        var v = i * 0.5, a = (i % 2 === 0) ? bold : fine;
        for (var j = -20; j < 20; j++)  // short segments: long lines through the camera
          a.push(v, j, 0, v, j + 1, 0, j, v, 0, j + 1, v, 0);  // plane get lost in clipping
      }
      [[fine, 0xcfd3d8], [bold, 0xa9aeb5]].forEach(function (gc) {
        var g = new THREE.BufferGeometry();
        g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(gc[0]), 3));
        scene3.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({color: gc[1]})));
      });
    })();

    var props = propMeshes(S, scene3);
    var robots = S.robots.map(function (R, k) { return robotView(S, R, k, scene3); });
    var P = S.pair ? {metrics: S.pair.metrics,
                      distanceMm: S.pair.distance_mm ? decode(S.pair.distance_mm) : null,
                      heldArr: S.pair.held ? decode(S.pair.held) : null} : null;
    var sims = robots.filter(function (r) { return r.sim; });
    var anySource = robots.some(function (r) { return r.source; });
    var anyHuman = robots.some(function (r) { return r.human; });

    // UI
    var slider = document.getElementById("frame"), label = document.getElementById("label");
    var info = document.getElementById("info"), playBtn = document.getElementById("play");
    var speedSel = document.getElementById("speed");
    slider.max = T - 1;
    var opts = {};
    ["human", "source", "edges", "floor", "beside", "follow", "sim", "sim-over", "props"].forEach(
        function (k) {
      var el = document.getElementById("opt-" + k);
      opts[k] = el;
      el.addEventListener("change", function () { setFrame(current); });
    });
    function hide(id) { document.getElementById(id).style.display = "none"; }
    if (!anySource) { opts.source.parentNode.style.display = "none"; hide("legend-source"); }
    if (!anySource && !anyHuman) opts.beside.parentNode.style.display = "none";
    if (!anyHuman) { opts.human.parentNode.style.display = "none";
                     opts.edges.parentNode.style.display = "none"; hide("legend-markers"); }
    if (!(S.props || []).length) { opts.props.parentNode.style.display = "none";
                                   hide("legend-props"); }
    if (robots.length < 2) hide("legend-b");
    var banner = document.getElementById("banner"), toFall = document.getElementById("to-fall");
    var fallFrame = -1;
    if (sims.length) {
      banner.textContent = sims.map(function (r) {
        return (robots.length > 1 ? r.entry.label + ": " : "") + r.sim.banner();
      }).join("  |  ");
      var fell = sims.filter(function (r) { return r.sim.fallFrame >= 0; });
      banner.className = fell.length ? "fell" : "stood";
      if (fell.length) {
        fallFrame = Math.min.apply(null, fell.map(function (r) { return r.sim.fallFrame; }));
        toFall.style.display = "";
        toFall.addEventListener("click", function () { play(false); setFrame(fallFrame); });
      }
    } else {
      ["sim", "sim-over"].forEach(function (k) { opts[k].parentNode.style.display = "none"; });
      hide("legend-sim");
      banner.style.display = "none";
    }

    function centre(t) {
      // the middle of the robots' roots at frame t
      var c = [0, 0, 0];
      robots.forEach(function (r) {
        var p = r.root(t);
        for (var i = 0; i < 3; i++) c[i] += p[i] / robots.length;
      });
      return c;
    }
    var spread = 0, c0 = centre(0);
    robots.forEach(function (r) {
      var p = r.root(0);
      spread = Math.max(spread, Math.hypot(p[0] - c0[0], p[1] - c0[1]));
    });
    var target = new THREE.Vector3(c0[0], c0[1], 0.8);
    var controls = new OrbitControl(camera, renderer.domElement, target, 4.6 + 2 * spread);
    controls.update();

    var current = 0, playing = false, clock = 0, last = null;
    function setFrame(t) {
      t = Math.max(0, Math.min(T - 1, Math.round(t)));
      current = t;
      slider.value = t;
      props.visible = opts.props.checked;
      var lines = ["frame " + t + " / " + (T - 1) + "  (" + (t / fps).toFixed(2) + " s)"];
      var warn = false;
      robots.forEach(function (r) {
        var out = r.set(t, opts, beside);
        lines = lines.concat(out.lines);
        warn = warn || out.warn;
      });
      var pl = pairLines(P, t);
      lines = lines.concat(pl.lines);
      if (opts.follow.checked) {
        var c = centre(t);
        target.x = c[0]; target.y = c[1];
        controls.update();
      }
      info.textContent = lines.join("\n");
      info.className = warn || pl.warn ? "warn" : "";
      label.textContent = t + " / " + (T - 1);
      renderer.render(scene3, camera);
    }

    function resize() {
      var w = host.clientWidth, h = host.clientHeight;
      renderer.setSize(w, h, false);
      camera.aspect = w / Math.max(h, 1);
      camera.updateProjectionMatrix();
      renderer.render(scene3, camera);
    }
    window.addEventListener("resize", resize);
    slider.addEventListener("input", function () { playing = false; playBtn.textContent = "play";
                                                   setFrame(+slider.value); });
    function play(on) {
      playing = on === undefined ? !playing : on;
      playBtn.textContent = playing ? "pause" : "play";
      last = null;
      if (playing && current >= T - 1) { clock = 0; setFrame(0); }
    }
    playBtn.addEventListener("click", function () { play(); });
    document.addEventListener("keydown", function (ev) {
      if (ev.key === " ") { ev.preventDefault(); play(); }
      if (ev.key === "ArrowRight") setFrame(current + 1);
      if (ev.key === "ArrowLeft") setFrame(current - 1);
      if ((ev.key === "s" || ev.key === "S") && sims.length) {
        opts.sim.checked = !opts.sim.checked;
        setFrame(current);
      }
    });
    function tick(now) {
      if (playing) {
        if (last !== null) clock += (now - last) / 1000 * parseFloat(speedSel.value);
        else clock = current / fps;
        last = now;
        var t = Math.floor(clock * fps);
        if (t >= T - 1) { setFrame(T - 1); play(false); } else if (t !== current) setFrame(t);
      }
      // an idle page draws only when something changes (setFrame, orbit, resize): a page
      // redrawn every animation frame keeps a report's compositor busy on its figures
      window.requestAnimationFrame(tick);
    }
    ["mousemove", "wheel"].forEach(function (n) {
      renderer.domElement.addEventListener(n, function () { renderer.render(scene3, camera); });
    });
    resize();
    setFrame(0);
    window.requestAnimationFrame(tick);
    document.getElementById("title").textContent = S.title;
    function snapshot(type, quality) {
      // the 3D view with the frame's text drawn in, as a data URL (videos)
      renderer.render(scene3, camera);
      var src = renderer.domElement, c = document.createElement("canvas");
      c.width = src.width; c.height = src.height;
      var g = c.getContext("2d"), k = src.width / Math.max(host.clientWidth, 1);
      g.drawImage(src, 0, 0);
      g.font = (13 * k) + "px sans-serif";
      var lines = info.textContent.split("\n");
      if (sims.length && opts.sim.checked) lines.unshift(banner.textContent);
      var w = 420 * k;
      lines.forEach(function (s2) { w = Math.max(w, g.measureText(s2).width + 12 * k); });
      g.fillStyle = "rgba(255,255,255,0.8)";
      g.fillRect(6 * k, 6 * k, w, (lines.length * 17 + 8) * k);
      g.fillStyle = info.className === "warn" ? "#b00" : "#222";
      lines.forEach(function (s2, i) { g.fillText(s2, 12 * k, (22 + 17 * i) * k); });
      return c.toDataURL(type || "image/png", quality);
    }
    window.imeshViewer = {
      snapshot: snapshot,
      frames: T, fps: fps, setFrame: function (t) { play(false); setFrame(t); return current; },
      simulation: function (k) {
        // what the page shows of robot k's DART simulation (tests): null without one
        var r = robots[k || 0], sim = r && r.sim;
        if (!sim) return null;
        var g = sim.groups[r.model.links.indexOf(r.model.root_link)] || sim.groups[0];
        return {visible: opts.sim.checked && g.visible, fallFrame: sim.fallFrame,
                root: [g.position.x, g.position.y, g.position.z],
                held: !sim.simulated[current], banner: banner.textContent};
      },
      robots: function () {
        // what the page shows of each robot at the current frame (tests)
        return robots.map(function (r) {
          var g = r.groups[r.model.links.indexOf(r.model.root_link)] || r.groups[0];
          var meshes = 0;
          r.groups.forEach(function (lg) { meshes += lg.children.length; });
          return {name: r.entry.name, label: r.entry.label, links: r.groups.length,
                  meshes: meshes, root: [g.position.x, g.position.y, g.position.z],
                  markers: !!r.human, source: !!r.source};
        });
      },
      props: function () {
        // the props drawn (tests): name, vertex count, visible
        return props.children.filter(function (o) { return o.isMesh; }).map(function (m) {
          return {name: m.name, vertices: m.geometry.attributes.position.count,
                  visible: props.visible};
        });
      },
      play: function () { play(true); }, pause: function () { play(false); },
      frame: function () { return current; }, ready: true
    };
    document.body.setAttribute("data-ready", "1");
  }

  function start() {
    loadScene().then(build).catch(function (err) {
      document.getElementById("info").textContent = "cannot show the motion: " + err;
      document.getElementById("info").className = "warn";
      throw err;
    });
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
