/* uavplan view: draws the document in #uavplan-data with plotly.js (inlined above this
 * script). No network: every value is in the page. window.uavplanView tells a test what
 * the page drew (ready, the traces by role, the replay). */
(function () {
  "use strict";
  var state = { ready: false, error: null };
  window.uavplanView = state;

  function fail(err) {
    state.error = String(err && err.stack ? err.stack : err);
    var box = document.getElementById("page-error");
    if (box) {
      box.textContent = "The page could not be drawn: " + String(err);
      box.hidden = false;
    }
    console.error(err);
  }

  function typed(a) {
    if (!a || typeof a !== "object" || !a.bdata) return a;
    var raw = atob(a.bdata);
    var bytes = new Uint8Array(raw.length);
    for (var i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
    var kinds = { f4: Float32Array, f8: Float64Array, u4: Uint32Array, i4: Int32Array };
    return new kinds[a.dtype](bytes.buffer);
  }

  function fmt(v, digits) {
    return v === null || v === undefined ? "–" : Number(v).toFixed(digits);
  }

  function el(tag, attrs, text) {
    var e = document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) { e.setAttribute(k, attrs[k]); });
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function clock(t) {
    var m = Math.floor(t / 60), s = t - 60 * m;
    return m + " min " + (s < 10 ? "0" : "") + s.toFixed(1) + " s";
  }

  var COLORS = {
    planned: "#1f77b4", red: "#e00000", flown: "#ff7f0e", back: "#8e44ad",
    waypoint: "#111111", vehicle: "#00a0ff", fenceIn: "#2ca02c", fenceOut: "#d62728",
  };

  function draw() {
    var doc = JSON.parse(document.getElementById("uavplan-data").textContent);
    state.doc = doc;
    var sc = doc.scene;
    var mission = doc.mission;
    var margin = sc.margin_m;
    var traces = [];
    var roles = {};
    function add(role, trace) {
      trace.meta = role;
      roles[role] = traces.length;
      traces.push(trace);
    }

    // --- verdict and legs table ---------------------------------------------------------
    var verdict = document.getElementById("verdict");
    var v = doc.verdict;
    verdict.className = v.ok === false ? "bad" : v.ok === true ? "good" : "neutral";
    v.problems.forEach(function (p) { verdict.appendChild(el("li", { "class": "problem" }, p)); });
    (v.warnings || []).forEach(function (p) { verdict.appendChild(el("li", { "class": "problem" }, p)); });
    v.lines.forEach(function (p) { verdict.appendChild(el("li", {}, p)); });

    // --- the ground and the ceiling -------------------------------------------------------
    if (sc.terrain) {
      var t = sc.terrain, ny = t.shape[0], nx = t.shape[1];
      var gz = typed(t.z), cz = typed(t.ceiling), rows = [], crows = [];
      for (var r = 0; r < ny; r++) {
        rows.push(Array.prototype.slice.call(gz.subarray(r * nx, (r + 1) * nx)));
        crows.push(Array.prototype.slice.call(cz.subarray(r * nx, (r + 1) * nx)));
      }
      add("terrain", {
        type: "surface", name: "ground (DEM)", x: t.x, y: t.y, z: rows,
        colorscale: "Earth", showscale: false, opacity: 1.0,
        hovertemplate: "ground %{z:.1f} m AMSL<br>(%{x:.0f}, %{y:.0f}) m<extra></extra>",
        lighting: { ambient: 0.7, diffuse: 0.6 }, showlegend: true,
      });
      add("ceiling", {
        type: "surface", name: "ceiling (" + t.ceiling_agl_m + " m above the ground)",
        x: t.x, y: t.y, z: crows, opacity: 0.18, showscale: false,
        colorscale: [[0, "#7f7fff"], [1, "#7f7fff"]], visible: "legendonly",
        hoverinfo: "skip", showlegend: true,
      });
    }

    // --- obstacles: one mesh, the ones a leg passes under the margin apart ----------------
    var mesh = sc.mesh, owner = typed(mesh.owner);
    var mx = typed(mesh.x), my = typed(mesh.y), mz = typed(mesh.z);
    var mi = typed(mesh.i), mj = typed(mesh.j), mk = typed(mesh.k);
    var close = {};
    if (mission) {
      Object.keys(mission.obstacles_near).forEach(function (id) {
        var d = mission.obstacles_near[id];
        if (d !== null && d < margin - 1e-6) close[id] = true;
      });
    }
    var texts = sc.obstacles.map(function (o, idx) {
      var s = o.name + "<br>" + o.kind + " at " + fmt(o.lat, 7) + ", " + fmt(o.lon, 7) +
        "<br>" + fmt(o.height_m, 1) + " m above the ground, top " + fmt(o.top_amsl_m, 1) +
        " m AMSL";
      if (o.nearest_m !== undefined && o.nearest_m !== null) {
        s += "<br>the route passes " + fmt(o.nearest_m, 2) + " m from it" +
          (close[idx] ? " (UNDER the " + margin + " m margin)" : "");
      }
      return s;
    });
    var hover = new Array(owner.length);
    for (var h = 0; h < owner.length; h++) hover[h] = texts[owner[h]];
    var keepI = [], keepJ = [], keepK = [], redI = [], redJ = [], redK = [];
    for (var f = 0; f < mi.length; f++) {
      var red = close[owner[mi[f]]];
      (red ? redI : keepI).push(mi[f]);
      (red ? redJ : keepJ).push(mj[f]);
      (red ? redK : keepK).push(mk[f]);
    }
    var base = {
      type: "mesh3d", x: mx, y: my, z: mz, hovertext: hover, hoverinfo: "text",
      flatshading: true, lighting: { ambient: 0.55, diffuse: 0.8, specular: 0.05 },
      lightposition: { x: -1e5, y: -1.5e5, z: 2e5 }, showlegend: true,
    };
    if (keepI.length) {
      add("obstacles", Object.assign({}, base, {
        name: "obstacles (" + sc.obstacles.length + ")", i: keepI, j: keepJ, k: keepK,
        intensity: mz, colorscale: [[0, "#8a8a8a"], [1, "#d9d9d9"]], showscale: false,
      }));
    }
    if (redI.length) {
      add("obstacles-close", Object.assign({}, base, {
        name: "obstacles passed under the margin", i: redI, j: redJ, k: redK,
        color: COLORS.red,
      }));
    }
    (sc.fence || []).forEach(function (zone) {
      var m = zone.mesh;
      add(zone.inclusion ? "fence-inclusion" : "fence-exclusion", {
        type: "mesh3d", x: typed(m.x), y: typed(m.y), z: typed(m.z), i: typed(m.i),
        j: typed(m.j), k: typed(m.k), color: zone.inclusion ? COLORS.fenceIn : COLORS.fenceOut,
        opacity: zone.inclusion ? 0.07 : 0.22, flatshading: true, hoverinfo: "name",
        name: zone.inclusion ? "geofence: inclusion" : "geofence: exclusion (" + zone.zones + ")",
        showlegend: true,
      });
    });

    // --- the flight bounds ----------------------------------------------------------------
    var b = sc.bounds, bx = [], by = [], bz = [];
    if (!sc.terrain) {
      var c = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]];
      [0, 1].forEach(function (zi) {
        c.forEach(function (p) { bx.push(b.x[p[0]]); by.push(b.y[p[1]]); bz.push(b.z[zi]); });
        bx.push(null); by.push(null); bz.push(null);
      });
      [[0, 0], [1, 0], [1, 1], [0, 1]].forEach(function (p) {
        bx.push(b.x[p[0]], b.x[p[0]], null); by.push(b.y[p[1]], b.y[p[1]], null);
        bz.push(b.z[0], b.z[1], null);
      });
      add("bounds", {
        type: "scatter3d", mode: "lines", x: bx, y: by, z: bz, name: "flight bounds",
        line: { color: "#999999", width: 2, dash: "dash" }, hoverinfo: "skip",
      });
    }

    // --- a scenario alone: its route points --------------------------------------------------
    if (doc.route_points) {
      var rp = doc.route_points;
      add("route-points", {
        type: "scatter3d", mode: "markers+text", x: rp.x, y: rp.y, z: rp.z,
        text: rp.text.map(function (s) { return s.split(":")[0]; }), hovertext: rp.text,
        hoverinfo: "text", name: "start, via points, goal",
        marker: { size: 5, color: "#2ca02c" },
      });
    }

    var vehicle = null, frames = null;
    if (mission) {
      var pl = mission.planned, legs = mission.legs;
      add("planned", {
        type: "scatter3d", mode: "lines", x: pl.x, y: pl.y, z: pl.z,
        name: "planned route (" + legs.length + " legs)",
        line: { color: COLORS.planned, width: 5 }, hoverinfo: "skip",
      });
      // the planned return (the legs after DO_LAND_START), over the planned line
      var px = [], py = [], pz = [];
      for (var u = 0; u < pl.leg.length; u++) {
        var pleg = legs[pl.leg[u]];
        if (!pleg || !pleg.planned_return) continue;
        px.push(pl.x[u], pl.x[u + 1], null); py.push(pl.y[u], pl.y[u + 1], null);
        pz.push(pl.z[u], pl.z[u + 1], null);
      }
      if (px.length) {
        add("planned-return", {
          type: "scatter3d", mode: "lines", x: px, y: py, z: pz,
          name: "the way home: the planned return", line: { color: COLORS.back, width: 6 },
          hoverinfo: "skip",
        });
      }
      // every red leg, drawn over the planned line
      var rx = [], ry = [], rz = [], rleg = [];
      for (var s = 0; s < pl.leg.length; s++) {
        var leg = legs[pl.leg[s]];
        if (!leg || !leg.red) continue;
        rx.push(pl.x[s], pl.x[s + 1], null); ry.push(pl.y[s], pl.y[s + 1], null);
        rz.push(pl.z[s], pl.z[s + 1], null); rleg.push(leg.leg, leg.leg, leg.leg);
      }
      if (rx.length) {
        add("red-legs", {
          type: "scatter3d", mode: "lines", x: rx, y: ry, z: rz, customdata: rleg,
          name: "legs under the " + margin + " m margin (" + mission.red_legs.join(", ") + ")",
          line: { color: COLORS.red, width: 9 }, hovertemplate: "leg %{customdata}<extra></extra>",
        });
      }
      var wp = mission.waypoints;
      var wtext = legs.map(function (l, n) {
        return "#" + l.leg + " " + l.command + " (item " + l.item + ", seq " + l.seq + ")" +
          (l.planned_return ? ", planned return" : "") +
          "<br>" + fmt(wp.lat[n], 7) + ", " + fmt(wp.lon[n], 7) +
          "<br>" + fmt(wp.z[n], 1) + " m AMSL, " + fmt(wp.agl[n], 1) + " m above the ground" +
          "<br>leg " + l.leg + " clearance: planned " + fmt(l.planned_m, 2) + " m" +
          (l.flown_m !== null ? ", flown " + fmt(l.flown_m, 2) + " m" : "") +
          (l.red ? " — UNDER the " + margin + " m margin" : "");
      });
      add("waypoints", {
        type: "scatter3d", mode: "markers+text", x: wp.x, y: wp.y, z: wp.z,
        text: legs.map(function (l) { return String(l.leg); }), textposition: "top center",
        hovertext: wtext, hoverinfo: "text", name: "waypoints (" + legs.length + ")",
        marker: {
          size: 4,
          color: legs.map(function (l) {
            return l.red ? COLORS.red : l.planned_return ? COLORS.back : COLORS.waypoint;
          }),
        },
        textfont: { size: 11, color: "#000" },
      });
      var fl = mission.flown;
      if (fl) {
        var line = fl.line, mx2 = [], my2 = [], mz2 = [], ox = [], oy = [], oz = [];
        for (var q = 0; q < line.sample.length; q++) {
          var back = fl.return_start !== null && line.sample[q] >= fl.return_start;
          var inMission = fl.return_start === null || line.sample[q] <= fl.return_start;
          if (inMission) { mx2.push(line.x[q]); my2.push(line.y[q]); mz2.push(line.z[q]); }
          if (back || (q + 1 < line.sample.length && fl.return_start !== null &&
            line.sample[q + 1] >= fl.return_start)) {
            ox.push(line.x[q]); oy.push(line.y[q]); oz.push(line.z[q]);
          }
        }
        add("flown", {
          type: "scatter3d", mode: "lines", x: mx2, y: my2, z: mz2,
          name: "as flown: " + fl.label, line: { color: COLORS.flown, width: 4 },
          hoverinfo: "skip",
        });
        if (ox.length) {
          add("return", {
            type: "scatter3d", mode: "lines", x: ox, y: oy, z: oz,
            name: "the way home: return to launch" +
              (fl.rtl_altitude_m !== null ? " at " + fl.rtl_altitude_m + " m" : ""),
            line: { color: COLORS.back, width: 4 }, hoverinfo: "skip",
          });
        }
        var fx = [], fy = [], fz = [];
        [fl.check, fl.return_check].forEach(function (ch) {
          if (!ch) return;
          for (var g = 0; g < ch.clearance.length; g++) {
            if (ch.clearance[g] !== null && ch.clearance[g] < margin - 1e-6) {
              fx.push(ch.x[g], ch.x[g + 1], null); fy.push(ch.y[g], ch.y[g + 1], null);
              fz.push(ch.z[g], ch.z[g + 1], null);
            }
          }
        });
        if (fx.length) {
          add("flown-red", {
            type: "scatter3d", mode: "lines", x: fx, y: fy, z: fz,
            name: "flown under the margin", line: { color: COLORS.red, width: 8, dash: "dot" },
            hoverinfo: "skip",
          });
        }
        frames = fl.frames;
        add("vehicle", {
          type: "scatter3d", mode: "markers", x: [frames.x[0]], y: [frames.y[0]],
          z: [frames.z[0]], name: "vehicle (replay)",
          marker: { size: 7, color: COLORS.vehicle, symbol: "diamond" }, hoverinfo: "skip",
        });
        vehicle = roles.vehicle;
      }
    }

    // --- the 3-D layout -------------------------------------------------------------------
    var rxm = b.x[1] - b.x[0], rym = b.y[1] - b.y[0];
    var zlo = b.z[0], zhi = b.z[1];
    if (sc.terrain) {
      var tz = typed(sc.terrain.z), tzc = typed(sc.terrain.ceiling);
      zlo = Math.min.apply(null, Array.prototype.slice.call(tz)) - 5;
      zhi = Math.max.apply(null, Array.prototype.slice.call(tzc));
    }
    var rzm = Math.max(zhi - zlo, 1);
    var wide = Math.max(rxm, rym);
    var stretch = Math.max(1, 0.25 * wide / rzm);
    var layout3d = {
      margin: { l: 0, r: 0, t: 0, b: 0 },
      showlegend: true,
      legend: { x: 0, y: 1, bgcolor: "rgba(255,255,255,0.75)", font: { size: 11 } },
      uirevision: "keep",
      scene: {
        aspectmode: "manual",
        aspectratio: { x: 1.3 * rxm / wide, y: 1.3 * rym / wide, z: 1.3 * rzm * stretch / wide },
        xaxis: { title: { text: "x east (m)" }, range: [b.x[0], b.x[1]] },
        yaxis: { title: { text: "y north (m)" }, range: [b.y[0], b.y[1]] },
        zaxis: {
          title: { text: "altitude (m AMSL" + (stretch > 1.05 ? ", ×" + stretch.toFixed(1) : "") + ")" },
          range: [zlo, zhi],
        },
        camera: { eye: { x: -0.95, y: -1.3, z: 0.8 } },
      },
      hoverlabel: { align: "left" },
    };
    var config = { responsive: true, displaylogo: false, scrollZoom: true };
    var div3d = document.getElementById("scene3d");
    var jobs = [Plotly.newPlot(div3d, traces, layout3d, config).then(function () {
      turnWithoutPicking(div3d);
    })];
    state.roles = roles;

    // --- legs table -----------------------------------------------------------------------
    if (mission) {
      var table = document.getElementById("legs");
      table.dataset.redLegs = mission.red_legs.join(",");
      var head = el("tr");
      ["leg", "to", "item", "planned (m)", "flown (m)"].forEach(function (hd) {
        head.appendChild(el("th", {}, hd));
      });
      table.appendChild(head);
      mission.legs.forEach(function (l) {
        var tr = el("tr", { "class": l.red ? "red" : "", "data-leg": String(l.leg) });
        [String(l.leg), l.command + (l.planned_return ? " (return)" : ""), String(l.item),
          fmt(l.planned_m, 2), fmt(l.flown_m, 2)].forEach(function (cell) {
          tr.appendChild(el("td", {}, cell));
        });
        table.appendChild(tr);
      });
      jobs.push(drawProfile(mission, margin));
    } else {
      document.getElementById("profile").textContent =
        "No mission: the profile and the replay need one.";
    }

    Promise.all(jobs).then(function () {
      if (frames) setUpReplay(div3d, vehicle, frames, mission);
      state.traces3d = div3d.data.length;
      state.ready = true;
      document.body.dataset.ready = "1";
    }).catch(fail);
  }

  function turnWithoutPicking(div) {
    // While a button is down the view turns: no hover then. plotly.js would render its
    // picking pass and read it back on every move, the most of a frame with a town's mesh.
    var down = false;
    function hover(mode) { return Plotly.relayout(div, { "scene.hovermode": mode }); }
    div.addEventListener("mousedown", function () {
      if (!down) { down = true; hover(false); }
    }, true);
    window.addEventListener("mouseup", function () {
      if (down) { down = false; hover("closest"); }
    }, true);
  }

  function stepXY(seg, s0, values) {
    // a step line: each segment's value from its start to its end
    var xs = [], ys = [];
    for (var g = 0; g < values.length; g++) {
      xs.push(s0[g], s0[g + 1], null); ys.push(values[g], values[g], null);
    }
    return [xs, ys];
  }

  function drawProfile(mission, margin) {
    var pr = mission.profile, pl = mission.planned, legs = mission.legs;
    var traces = [], roles = {};
    function add(role, trace) { trace.meta = role; roles[role] = traces.length; traces.push(trace); }
    var tops = pr.obstacle_top.map(function (t, n) {
      return t === null ? pr.ground[n] : Math.max(t, pr.ground[n]);
    });
    var lowest = Math.min.apply(null, pr.ground.filter(function (g) { return g !== null; }));
    add("ground", {
      x: pr.s, y: pr.ground, name: "ground", mode: "lines", line: { color: "#8c6d31", width: 1 },
      fill: "tozeroy", fillcolor: "rgba(140,109,49,0.35)", hovertemplate: "ground %{y:.1f} m AMSL<extra></extra>",
    });
    add("obstacle-tops", {
      x: pr.s, y: tops, name: "obstacle tops beneath", mode: "lines",
      line: { color: "#555", width: 1 }, fill: "tonexty", fillcolor: "rgba(90,90,90,0.45)",
      hovertemplate: "top %{y:.1f} m AMSL<extra></extra>",
    });
    add("planned-alt", {
      x: pr.line_s, y: pl.z, name: "planned altitude", mode: "lines",
      line: { color: "#1f77b4", width: 2 }, hovertemplate: "%{y:.1f} m AMSL at %{x:.0f} m<extra></extra>",
    });
    var rx = [], ry = [], rleg = [];
    for (var s = 0; s < pl.leg.length; s++) {
      var leg = legs[pl.leg[s]];
      if (!leg || !leg.red) continue;
      rx.push(pr.line_s[s], pr.line_s[s + 1], null); ry.push(pl.z[s], pl.z[s + 1], null);
      rleg.push(leg.leg, leg.leg, leg.leg);
    }
    if (rx.length) {
      add("profile-red-legs", {
        x: rx, y: ry, customdata: rleg, name: "legs under the margin", mode: "lines",
        line: { color: "#e00000", width: 5 }, hovertemplate: "leg %{customdata}<extra></extra>",
      });
    }
    var fl = mission.flown;
    if (fl) {
      var fs = [], fz = [], bs = [], bz = [];
      fl.profile.sample.forEach(function (smp, n) {
        var onWay = fl.return_start === null || smp <= fl.return_start;
        var backWay = fl.return_start !== null && smp >= fl.return_start;
        if (onWay) { fs.push(fl.profile.s[n]); fz.push(fl.profile.z[n]); }
        if (backWay) { bs.push(fl.profile.s[n]); bz.push(fl.profile.z[n]); }
      });
      add("flown-alt", {
        x: fs, y: fz, name: "as flown", mode: "lines",
        line: { color: "#ff7f0e", width: 1.5 }, hovertemplate: "flown %{y:.1f} m AMSL<extra></extra>",
      });
      if (bs.length) {
        add("return-alt", {
          x: bs, y: bz, name: "the way home (beyond the route's end)", mode: "lines",
          line: { color: "#8e44ad", width: 1.5 },
          hovertemplate: "return %{y:.1f} m AMSL<extra></extra>",
        });
      }
    }
    // the clearance, segment by segment, below
    var st = stepXY(pl.leg, pr.line_s, pl.clearance);
    add("planned-clearance", {
      x: st[0], y: st[1], yaxis: "y2", name: "clearance planned", mode: "lines",
      line: { color: "#1f77b4", width: 1.5 }, hovertemplate: "%{y:.2f} m<extra>planned</extra>",
    });
    var minS = null, minV = Infinity, minWhat = "";
    for (var g = 0; g < pl.clearance.length; g++) {
      if (pl.clearance[g] !== null && pl.clearance[g] < minV) {
        minV = pl.clearance[g]; minS = 0.5 * (pr.line_s[g] + pr.line_s[g + 1]); minWhat = "planned";
      }
    }
    if (fl) {
      var along = fl.profile.s, samples = fl.profile.sample;
      var sAt = function (sample) {
        // the sample's place along the line (the nearest drawn sample at or before it)
        var lo = 0, hi = samples.length - 1;
        while (lo < hi) { var mid = (lo + hi + 1) >> 1; if (samples[mid] <= sample) lo = mid; else hi = mid - 1; }
        return along[lo];
      };
      [["flown-clearance", fl.check, "as flown", "#ff7f0e"],
        ["return-clearance", fl.return_check, "the way home", "#8e44ad"]].forEach(function (part) {
        var ch = part[1], sx = [], sy = [];
        if (!ch) return;
        for (var c = 0; c < ch.clearance.length; c++) {
          var a = sAt(ch.sample[c]), e = sAt(ch.sample[c + 1]);
          sx.push(a, e, null); sy.push(ch.clearance[c], ch.clearance[c], null);
          if (ch.clearance[c] !== null && ch.clearance[c] < minV) {
            minV = ch.clearance[c]; minS = 0.5 * (a + e); minWhat = part[2];
          }
        }
        add(part[0], {
          x: sx, y: sy, yaxis: "y2", name: "clearance " + part[2], mode: "lines",
          line: { color: part[3], width: 1.5 }, hovertemplate: "%{y:.2f} m<extra>" + part[2] + "</extra>",
        });
      });
    }
    if (minS !== null) {
      add("minimum", {
        x: [minS], y: [minV], yaxis: "y2", mode: "markers+text", name: "minimum",
        text: ["min " + minV.toFixed(2) + " m (" + minWhat + ")"], textposition: "top right",
        marker: { size: 10, color: minV < margin - 1e-6 ? "#e00000" : "#2ca02c", symbol: "x" },
        hovertemplate: "minimum clearance %{y:.2f} m<extra></extra>",
      });
    }
    var top = Math.max.apply(null, pl.z.concat(fl ? fl.profile.z : []).filter(function (q) { return q !== null; }));
    var clearTop = Math.max(3 * margin, Math.min(minV === Infinity ? 3 * margin : minV * 3, 8 * margin));
    var layout = {
      margin: { l: 60, r: 20, t: 34, b: 40 },
      xaxis: { title: { text: "distance along the planned route (m)" }, zeroline: false, anchor: "y2" },
      yaxis: { title: { text: "altitude (m AMSL)" }, domain: [0.42, 1], range: [lowest - 5, top + 0.08 * (top - lowest) + 5] },
      yaxis2: { title: { text: "clearance (m)" }, domain: [0, 0.34], range: [0, clearTop], anchor: "x" },
      shapes: [{
        type: "line", xref: "paper", x0: 0, x1: 1, yref: "y2", y0: margin, y1: margin,
        line: { color: "#e00000", width: 1.5, dash: "dash" },
      }].concat(fl ? [{
        // the replay's cursor: a shape moves without redrawing the traces
        type: "line", xref: "x", x0: fl.frames.s[0], x1: fl.frames.s[0], yref: "paper",
        y0: 0, y1: 1, line: { color: "#00a0ff", width: 2 },
      }] : []),
      annotations: [{
        xref: "paper", x: 1, yref: "y2", y: margin, xanchor: "right", yanchor: "bottom",
        text: "margin " + margin + " m", showarrow: false, font: { color: "#e00000", size: 11 },
      }],
      legend: { orientation: "h", x: 0, y: 1.0, yanchor: "bottom" },
      hovermode: "closest",
    };
    state.profileRoles = roles;
    return Plotly.newPlot(document.getElementById("profile"), traces, layout,
      { responsive: true, displaylogo: false });
  }

  function setUpReplay(div3d, vehicle, frames, mission) {
    var slider = document.getElementById("replay");
    var readout = document.getElementById("readout");
    var play = document.getElementById("play");
    var prof = document.getElementById("profile");
    document.getElementById("replay-box").hidden = false;
    slider.max = String(frames.t.length - 1);
    slider.value = "0";
    var pending = null, timer = null;
    function show(n) {
      var legs = mission.legs;
      var leg = frames.leg[n] < legs.length ? "leg " + legs[frames.leg[n]].leg : "the way home";
      readout.textContent = clock(frames.t[n]) + " · item " + frames.seq[n] + " (" + leg + ") · " +
        fmt(frames.speed[n], 1) + " m/s · battery " +
        (frames.battery ? fmt(frames.battery[n], 0) + " % left" : "not recorded") + " · " +
        fmt(frames.z[n], 1) + " m AMSL, " + fmt(frames.agl[n], 1) + " m above the ground" +
        (frames.mode && frames.mode[n] ? " · " + frames.mode[n] : "");
      state.frame = n;
      var jobs = [Plotly.restyle(div3d, { x: [[frames.x[n]]], y: [[frames.y[n]]], z: [[frames.z[n]]] }, [vehicle])];
      jobs.push(Plotly.relayout(prof, { "shapes[1].x0": frames.s[n], "shapes[1].x1": frames.s[n] }));
      return Promise.all(jobs);
    }
    state.show = show;
    slider.addEventListener("input", function () {
      var n = Number(slider.value);
      if (pending === null) {
        pending = requestAnimationFrame(function () { pending = null; show(Number(slider.value)); });
      }
      state.frame = n;
    });
    play.addEventListener("click", function () {
      if (timer) { timer = null; play.textContent = "▶ play"; return; }
      play.textContent = "❚❚ pause";
      var token = timer = {};
      // one position after the other, each once the last is drawn (a slow machine skips none
      // and piles up nothing)
      function next() {
        if (timer !== token) return;
        var n = Number(slider.value) + 1;
        if (n > Number(slider.max)) { timer = null; play.textContent = "▶ play"; return; }
        slider.value = String(n);
        show(n).then(function () { setTimeout(next, 40); });
      }
      next();
    });
    show(0);
  }

  window.addEventListener("error", function (e) { fail(e.error || e.message); });
  try {
    if (typeof Plotly === "undefined") throw new Error("plotly.js is missing from the page");
    draw();
  } catch (err) {
    fail(err);
  }
})();
