// The warehouse plan in SVG, from GET /api/scenarios/{name}/plan: floor, zones, objects by their
// footprints, the marked route and task, and over it the truck's path and the session's events
// where they happened. World x to the right, y up (the SVG's y runs down, so it is flipped here);
// one SVG unit is one metre. A manoeuvre has no layout: its path is drawn on a grid. The plan
// zooms (wheel, buttons, drag to pan) with its event markers kept the same size on screen and
// spread apart where several happened in one place; the replay draws the truck over it (its overlay),
// and the live page and the replay the people who move (hi-vis figures) where they are.
'use strict';

const FLPlan = (() => {
  const { svg, el, clear } = FL;

  const OBJECT_FILL = { rack: '#4a6fa5', pallet: '#b07d48', wall: '#444', door: '#d9d9d9', dock: '#9aa5b1',
                        lorry: '#2f6b3b', cone: '#f28c28', obstacle: '#7b8794', pedestrian: '#8e44ad' };
  const ZONE_FILL = { walkway: '#fff3a3', corner: '#e8eef5', dock: '#e3e7eb', ramp: '#dbeafe' };
  const WORRY_FILL = { 0: '#8c959f', 1: '#d4a72c', 3: '#e16f24', 5: '#b42318' };

  function corners(o) {
    const [x0, y0, x1, y1] = o.footprint_m || [-0.3, -0.3, 0.3, 0.3];
    const a = (o.yaw_deg || 0) * Math.PI / 180, c = Math.cos(a), s = Math.sin(a);
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]].map(([x, y]) => [o.x_m + c * x - s * y, o.y_m + s * x + c * y]);
  }

  // A person in a high-visibility vest, seen from above: yellow with an orange band; red once struck.
  const PERSON = { vest: '#ffd400', band: '#e8590c', struck: '#b42318' };
  const SPILL = '#7a5a2e';  // oil on the floor
  // What a person who moves is doing, in the page's words (an activity no catalogue knows as it is).
  const activityWords = (a) => (FL.has(`plan.activity.${a}`) ? FL.t(`plan.activity.${a}`) : a);
  const t = (key, vars) => FL.t(key, vars);
  const truckWords = (a) => (FL.has(`plan.truck_activity.${a}`) ? FL.t(`plan.truck_activity.${a}`) : a);

  function niceStep(span) {
    for (const s of [0.5, 1, 2, 5, 10, 20, 50, 100]) if (span / s <= 14) return s;
    return 200;
  }

  // Draws into `container`; returns { select(seq) } to mark one event as the current one.
  function draw(container, { plan, path, events, title, onEvent }) {
    const pts = [];
    const objects = plan ? plan.objects || [] : [];
    // A manoeuvre's floor is a large default with nothing on it: the path sets the bounds then.
    const floor = plan && plan.floor_m && objects.length ? plan.floor_m : null;
    if (floor) pts.push([floor[0], floor[1]], [floor[2], floor[3]]);
    for (const o of objects) pts.push(...corners(o));
    if (plan && plan.route) pts.push(...plan.route.points);
    if (plan && plan.start) pts.push([plan.start.x_m, plan.start.y_m]);
    for (const p of path) pts.push([p.x_m, p.y_m]);
    for (const e of events) pts.push([e.x_m, e.y_m]);
    if (pts.length === 0) pts.push([0, 0]);
    let minX = Math.min(...pts.map((p) => p[0])), maxX = Math.max(...pts.map((p) => p[0]));
    let minY = Math.min(...pts.map((p) => p[1])), maxY = Math.max(...pts.map((p) => p[1]));
    // at least 10 m across, and a margin
    const grow = (lo, hi) => { const m = Math.max(0, 10 - (hi - lo)) / 2 + 1.5; return [lo - m, hi + m]; };
    [minX, maxX] = grow(minX, maxX);
    [minY, maxY] = grow(minY, maxY);
    const W = maxX - minX, H = maxY - minY, u = Math.max(W, H) / 120;
    const X = (x) => +(x - minX).toFixed(3), Y = (y) => +(maxY - y).toFixed(3);
    const poly = (ps) => ps.map(([x, y]) => `${X(x)},${Y(y)}`).join(' ');

    const root = svg('svg', { class: 'plan', viewBox: `0 0 ${W.toFixed(3)} ${H.toFixed(3)}`, role: 'img',
                              'aria-labelledby': 'plan-title plan-desc', id: 'plan-svg' });
    const last = path[path.length - 1];
    root.append(svg('title', { id: 'plan-title' }, title),
                svg('desc', { id: 'plan-desc' }, path.length === 0 ? t('plan.no_path')
                  : t('plan.desc', { points: path.length, time: FL.num(last.t), x: FL.num(last.x_m), y: FL.num(last.y_m), events: events.length })));

    // the floor and its zones
    if (floor) {
      const [x0, y0, x1, y1] = floor;
      root.append(svg('rect', { x: X(x0), y: Y(y1), width: x1 - x0, height: y1 - y0, fill: '#f6f6f1', stroke: '#bbb', 'stroke-width': u * 0.2 }));
    }
    for (const z of plan ? plan.zones || [] : []) {
      const fill = ZONE_FILL[z.kind];
      if (fill) root.append(svg('polygon', { points: poly(z.polygon), fill, opacity: 0.8 }, svg('title', {}, `${z.id}: ${z.kind}, ${z.speed_limit_m_s} m/s`)));
    }
    // the spills: one on the floor filled, one still to come (its cue, or the instructor's) outlined
    // until the live state says it is down (showSpills)
    const spillRects = [];
    (plan ? plan.spills || [] : []).forEach((sp, i) => {
      const [x0, y0, x1, y1] = sp.rect, grip = Math.round(sp.friction_scale * 100);
      const r = svg('rect', { class: 'spill', 'data-spill': sp.id, x: X(x0), y: Y(y1), width: +(x1 - x0).toFixed(3), height: +(y1 - y0).toFixed(3),
                              fill: SPILL, stroke: SPILL, 'stroke-width': u * 0.25 }, svg('title', {}));
      spillRects[i] = { r, sp, grip };
      root.append(r);
    });
    const showSpills = (onFloor) => {
      spillRects.forEach(({ r, sp, grip }, i) => {
        const down = !sp.triggered || onFloor.has(i);
        r.dataset.onFloor = String(down);
        r.setAttribute('fill-opacity', down ? '0.45' : '0');
        r.setAttribute('stroke-dasharray', down ? 'none' : `${u} ${u * 0.6}`);
        r.firstChild.textContent = t(down ? 'plan.spill' : 'plan.spill_to_come', { id: sp.id, grip });
      });
    };
    showSpills(new Set());
    // a grid, every `step` metres
    const step = niceStep(Math.max(W, H));
    const grid = svg('g', { stroke: '#d0d7de', 'stroke-width': u * 0.12 });
    for (let x = Math.ceil(minX / step) * step; x <= maxX; x += step) grid.append(svg('line', { x1: X(x), y1: 0, x2: X(x), y2: H }));
    for (let y = Math.ceil(minY / step) * step; y <= maxY; y += step) grid.append(svg('line', { x1: 0, y1: Y(y), x2: W, y2: Y(y) }));
    root.append(grid);
    // a scale bar
    root.append(svg('g', {}, svg('line', { x1: u * 2, y1: H - u * 2, x2: u * 2 + step, y2: H - u * 2, stroke: '#222', 'stroke-width': u * 0.4 }),
                    svg('text', { x: u * 2, y: H - u * 3, 'font-size': u * 2.6, fill: '#222' }, `${step} m`)));

    // the objects
    for (const o of objects) {
      root.append(svg('polygon', { points: poly(corners(o)), fill: OBJECT_FILL[o.kind] || '#888', stroke: '#222', 'stroke-width': u * 0.1,
                                   'data-object': o.id }, svg('title', {}, `${o.id} (${o.kind})`)));
    }
    // the route and the task
    if (plan && plan.route && plan.route.points.length > 1) {
      if (plan.route.width_m > 0)
        root.append(svg('polyline', { points: poly(plan.route.points), fill: 'none', stroke: '#2da44e', 'stroke-opacity': 0.12,
                                      'stroke-width': plan.route.width_m, 'stroke-linejoin': 'round', 'stroke-linecap': 'round' }));
      root.append(svg('polyline', { points: poly(plan.route.points), fill: 'none', stroke: '#555', 'stroke-width': u * 0.3,
                                    'stroke-dasharray': `${u * 1.5} ${u}` }, svg('title', {}, t('plan.route'))));
    }
    for (const s of plan && plan.task ? plan.task.steps : []) {
      if (s.kind === 'pass')
        root.append(svg('line', { x1: X(s.gate_a[0]), y1: Y(s.gate_a[1]), x2: X(s.gate_b[0]), y2: Y(s.gate_b[1]), stroke: '#2da44e',
                                  'stroke-width': u * 0.5 }, svg('title', {}, s.description)));
      else if (s.point)
        root.append(svg('circle', { cx: X(s.point[0]), cy: Y(s.point[1]), r: Math.max(s.radius_m || 0, u), fill: 'none', stroke: '#2da44e',
                                    'stroke-width': u * 0.4, 'stroke-dasharray': `${u} ${u * 0.6}` }, svg('title', {}, s.description)));
    }
    // the start, the path and where the truck ended
    const arrow = (x, y, yawDeg, fill, label) => {
      const a = yawDeg * Math.PI / 180, L = u * 3;
      const tip = [x + Math.cos(a) * L, y + Math.sin(a) * L];
      const l = [x + Math.cos(a + 2.5) * L * 0.6, y + Math.sin(a + 2.5) * L * 0.6];
      const r = [x + Math.cos(a - 2.5) * L * 0.6, y + Math.sin(a - 2.5) * L * 0.6];
      return svg('polygon', { points: poly([tip, l, r]), fill, stroke: '#fff', 'stroke-width': u * 0.2 }, svg('title', {}, label));
    };
    if (plan && plan.start) root.append(arrow(plan.start.x_m, plan.start.y_m, plan.start.yaw_deg || 0, '#57606a', t('plan.start')));
    if (path.length > 1)
      root.append(svg('polyline', { id: 'truck-path', points: poly(path.map((p) => [p.x_m, p.y_m])), fill: 'none', stroke: '#0b5cad',
                                    'stroke-width': u * 0.6, 'stroke-linejoin': 'round', 'data-points': path.length },
                      svg('title', {}, t('plan.path'))));
    if (last) root.append(arrow(last.x_m, last.y_m, last.yaw_deg, '#0b5cad', t('plan.truck_at', { time: FL.num(last.t) })));

    // the paths the scenario's people walk, first point to last (where each is comes with the
    // live state and the replay)
    for (const p of plan ? plan.pedestrians || [] : []) {
      if (!p.path || p.path.length < 2) continue;
      root.append(svg('polyline', { points: poly(p.path), fill: 'none', stroke: PERSON.band, 'stroke-width': u * 0.35,
                                    'stroke-dasharray': `${u * 0.8} ${u * 0.6}`, 'data-walk': p.id },
                      svg('title', {}, t('plan.walks', { id: p.id }) + (p.looks ? '' : t('plan.does_not_look')))));
    }

    // the other trucks' routes and the crossings (who goes first in each one's title)
    for (const c of plan ? plan.crossings || [] : []) {
      if (!c.polygon || c.polygon.length < 3) continue;
      root.append(svg('polygon', { points: poly(c.polygon), fill: 'none', stroke: '#b35900', 'stroke-width': u * 0.3,
                                   'stroke-dasharray': `${u * 0.5} ${u * 0.5}`, 'data-crossing': c.id },
                      svg('title', {}, t(c.priority === 'pupil' ? 'plan.crossing_pupil_first' : 'plan.crossing_traffic_first', { id: c.id }))));
    }
    for (const other of plan ? plan.trucks || [] : []) {
      if (!other.route || other.route.length < 2) continue;
      root.append(svg(other.loop ? 'polygon' : 'polyline', { points: poly(other.route), fill: 'none', stroke: '#7b8794', 'stroke-width': u * 0.4,
                                                             'stroke-dasharray': `${u * 1.2} ${u * 0.6}`, 'data-route': other.id },
                      svg('title', {}, t(other.loop ? 'plan.truck_route_loop' : 'plan.truck_route', { id: other.id }))));
    }

    // the replay's truck and moving pallets, over the plan and under the event markers
    const overlay = svg('g', { class: 'overlay' });
    root.append(overlay);

    // the events, numbered as in the timeline; events within a marker's width of each other are
    // spread round their place, so that each can be seen and clicked.
    const marks = new Map(), scaled = [];
    const near = [];
    for (const e of events) {
      let group = near.find((g) => Math.hypot(g.x - e.x_m, g.y - e.y_m) < u * 3);
      if (!group) near.push(group = { x: e.x_m, y: e.y_m, members: [] });
      group.members.push(e);
    }
    for (const group of near) {
      group.members.forEach((e, i) => {
        const n = group.members.length, a = 2 * Math.PI * i / n, spread = n > 1 ? u * 2 : 0;
        const cx = X(e.x_m), cy = Y(e.y_m), dx = Math.cos(a) * spread, dy = -Math.sin(a) * spread;
        const g = svg('g', { class: 'event', 'data-seq': e.seq, 'aria-hidden': 'true' },
          n > 1 ? svg('line', { x1: cx, y1: cy, x2: cx + dx, y2: cy + dy, stroke: '#555', 'stroke-width': u * 0.15 }) : null,
          svg('circle', { cx: cx + dx, cy: cy + dy, r: u * 1.6, fill: WORRY_FILL[e.worry_level] || '#555', stroke: '#fff', 'stroke-width': u * 0.2 }),
          svg('text', { x: cx + dx, y: cy + dy + u * 0.8, 'text-anchor': 'middle', 'font-size': u * 2.2, fill: '#fff', 'font-weight': 700 }, e.seq),
          svg('title', {}, t('plan.event', { seq: e.seq, title: e.words ? e.words.title : e.kind, worry: FL.worryName(e.worry_level), time: FL.num(e.sim_time_s) })));
        if (onEvent) g.addEventListener('click', () => onEvent(e.seq));
        marks.set(e.seq, g);
        scaled.push({ g, cx, cy });
        root.append(g);
      });
    }

    // Zoom: the view box shrinks round a point; markers and the truck keep their size on screen.
    const full = { x: 0, y: 0, w: W, h: H };
    let view = { ...full };
    function applyView() {
      root.setAttribute('viewBox', `${view.x.toFixed(3)} ${view.y.toFixed(3)} ${view.w.toFixed(3)} ${view.h.toFixed(3)}`);
      const k = view.w / W;  // 1 at full view, smaller zoomed in
      for (const { g, cx, cy } of scaled) g.setAttribute('transform', `translate(${cx} ${cy}) scale(${k}) translate(${-cx} ${-cy})`);
      root.dataset.zoom = (1 / k).toFixed(2);
    }
    function zoomAt(factor, px = view.x + view.w / 2, py = view.y + view.h / 2) {
      const w = Math.min(W, Math.max(W / 40, view.w / factor)), h = w * H / W;
      view = { x: px - (px - view.x) * w / view.w, y: py - (py - view.y) * h / view.h, w, h };
      view.x = Math.min(Math.max(view.x, 0), W - w);
      view.y = Math.min(Math.max(view.y, 0), H - h);
      applyView();
    }
    function toSvg(ev) {
      const r = root.getBoundingClientRect();
      return [view.x + (ev.clientX - r.left) / r.width * view.w, view.y + (ev.clientY - r.top) / r.height * view.h];
    }
    root.addEventListener('wheel', (ev) => { ev.preventDefault(); zoomAt(ev.deltaY < 0 ? 1.25 : 0.8, ...toSvg(ev)); }, { passive: false });
    let drag = null;
    root.addEventListener('pointerdown', (ev) => { if (view.w < W) { drag = toSvg(ev); root.setPointerCapture(ev.pointerId); } });
    root.addEventListener('pointermove', (ev) => {
      if (!drag) return;
      const [x, y] = toSvg(ev);
      view.x = Math.min(Math.max(view.x + drag[0] - x, 0), W - view.w);
      view.y = Math.min(Math.max(view.y + drag[1] - y, 0), H - view.h);
      applyView();
    });
    root.addEventListener('pointerup', () => { drag = null; });
    const zoomBar = el('div', { class: 'zoom', role: 'group', 'aria-label': t('plan.zoom') },
      el('button', { type: 'button', class: 'secondary', id: 'zoom-in', 'aria-label': t('plan.zoom_in'), onclick: () => zoomAt(1.5) }, '+'),
      el('button', { type: 'button', class: 'secondary', id: 'zoom-out', 'aria-label': t('plan.zoom_out'), onclick: () => zoomAt(1 / 1.5) }, '−'),
      el('button', { type: 'button', class: 'secondary', id: 'zoom-reset', onclick: () => { view = { ...full }; applyView(); } }, t('plan.whole')));

    clear(container).append(zoomBar, root);
    applyView();
    return {
      select(seq) {
        for (const [s, g] of marks) g.classList.toggle('current', s === seq);
        const g = marks.get(seq);
        if (g) root.append(g);  // on top
      },
      // Keeps a world point (the replay's truck) in the middle of a zoomed view: moves the view
      // only when the point nears its edge, so that the plan does not jitter.
      keepInView(x, y) {
        if (view.w >= W) return;
        const px = X(x), py = Y(y), mx = view.w * 0.2, my = view.h * 0.2;
        if (px > view.x + mx && px < view.x + view.w - mx && py > view.y + my && py < view.y + view.h - my) return;
        view.x = Math.min(Math.max(px - view.w / 2, 0), W - view.w);
        view.y = Math.min(Math.max(py - view.h / 2, 0), H - view.h);
        applyView();
      },
      zoomAt,
      // What the replay draws with: the overlay group (above the plan, under the markers), world
      // to SVG coordinates, one marker unit, and the plan's objects by id (pallets move).
      overlay, X, Y, u, objectsById: new Map(objects.map((o) => [o.id, o])),
      // The people who move, as hi-vis figures facing their heading: [{id, x_m, y_m, heading_deg,
      // activity}]. A group for the overlay; each figure names him and what he is doing.
      people(list) {
        const g = svg('g', { class: 'people' });
        for (const p of list) {
          const a = p.heading_deg * Math.PI / 180, r = Math.max(0.3, u * 1.1), struck = p.activity === 'struck';
          const cx = X(p.x_m), cy = Y(p.y_m);
          g.append(svg('g', { class: 'person', 'data-pedestrian': p.id, 'data-activity': p.activity,
                              'data-x': p.x_m.toFixed(3), 'data-y': p.y_m.toFixed(3) },
            svg('circle', { cx, cy, r, fill: struck ? PERSON.struck : PERSON.vest, stroke: PERSON.band, 'stroke-width': r * 0.35 }),
            svg('line', { x1: cx, y1: cy, x2: +(cx + Math.cos(a) * r * 1.6).toFixed(3), y2: +(cy - Math.sin(a) * r * 1.6).toFixed(3),
                          stroke: '#222', 'stroke-width': r * 0.3, 'stroke-linecap': 'round' }),
            svg('title', {}, t('plan.person', { id: p.id, activity: activityWords(p.activity), x: FL.num(p.x_m), y: FL.num(p.y_m) }))));
        }
        return g;
      },
      activityWords,
      // The other trucks, as boxes of their plan size facing their heading: [{id, x_m, y_m,
      // heading_deg, activity}]. A group for the overlay; each names the truck and what it does.
      trucks(list) {
        const g = svg('g', { class: 'trucks' });
        const size = new Map((plan ? plan.trucks || [] : []).map((t) => [t.id, t.size_m || [3, 1.1, 2.1]]));
        for (const truck of list) {
          const [l, w] = size.get(truck.id) || [3, 1.1];
          const cx = X(truck.x_m), cy = Y(truck.y_m);
          g.append(svg('rect', { class: 'other-truck', 'data-truck': truck.id, 'data-activity': truck.activity,
                                 'data-x': truck.x_m.toFixed(3), 'data-y': truck.y_m.toFixed(3),
                                 x: cx - X(l / 2) + X(0), y: cy - (Y(0) - Y(w / 2)), width: X(l) - X(0), height: Y(0) - Y(w),
                                 transform: `rotate(${-truck.heading_deg} ${cx} ${cy})`,
                                 fill: truck.activity === 'struck' ? '#c0392b' : '#f28c28', stroke: '#222', 'stroke-width': u * 0.2 },
            svg('title', {}, t('plan.other_truck', { id: truck.id, activity: truckWords(truck.activity), x: FL.num(truck.x_m), y: FL.num(truck.y_m) }))));
        }
        return g;
      },
      truckWords,
      shapeOf: (id) => root.querySelector(`[data-object="${CSS.escape(id)}"]`),
      // The spills with a cue that are on the floor now: their places in the plan's spills.
      showSpills: (places) => showSpills(new Set(places || [])),
    };
  }

  return { draw };
})();
