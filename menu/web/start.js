// Scenario choice: pupil, scenario, truck, load and cab; POST /api/sessions starts it, and the
// page follows the session until it ends, with an abort button.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, num, param, stateText, reasonText } = FL;
  const me = requireLogin(FL.STAFF);
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  let scenarios = [], trucks = [], session = null;

  function loadText(l) {
    return l ? `${num(l.mass_kg, 0)} kg, centre of gravity ${num(l.cog_height_m ?? 0.6, 2)} m up` : 'no load';
  }

  function aboutScenario() {
    const s = scenarios.find((x) => x.name === $('scenario').value);
    if (!s) return;
    const bits = [];
    if (s.description) bits.push(s.description);
    if (s.time_limit_s || s.duration_s) bits.push(`Time: ${s.time_limit_s || s.duration_s} s.`);
    $('scenario-about').textContent = bits.join(' ');
    $('load-scenario-about').textContent = `(${loadText(s.load)})`;
  }

  function aboutTruck() {
    const t = trucks.find((x) => x.name === $('truck').value);
    const s = scenarios.find((x) => x.name === $('scenario').value);
    const shown = t || trucks.find((x) => s && x.name === s.truck);
    $('truck-about').textContent = shown ? `${shown.title}: rated ${shown.rated_capacity_kg} kg at a ${shown.rated_load_centre_m} m load centre${shown.osha_class ? `; ${shown.osha_class}` : ''}.` : '';
  }

  function customLoad() {
    const on = $('load-custom').checked;
    for (const id of ['mass', 'height', 'lateral']) $(id).disabled = !on;
  }

  async function follow() {
    if (!session) return;
    try {
      const s = await api('GET', `/sessions/${encodeURIComponent(session)}`);
      const over = ['ended', 'failed', 'aborted'].includes(s.state);
      $('started-status').textContent = `Session ${s.id} for pupil ${s.pupil_id} on cab ${s.cab_id}: ${stateText(s.state)}${s.reason ? ` (${reasonText(s.reason)})` : ''}.`;
      $('abort').hidden = over;
      if (over) { session = null; $('start-button').disabled = false; return; }
    } catch (e) {
      say(message, describeError(e));
    }
    setTimeout(follow, 1000);
  }

  $('abort').addEventListener('click', async () => {
    if (!session) return;
    try { await api('POST', `/sessions/${encodeURIComponent(session)}/abort`); } catch (e) { say(message, describeError(e)); }
  });

  $('start').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    clear(message);
    const body = { pupil_id: Number($('pupil').value), scenario: $('scenario').value, cab_id: $('cab').value.trim(), mode: $('mode').value };
    if (!body.pupil_id) { say(message, 'Choose a pupil: type part of their name and pick them from the list (add one on the Pupils page).'); $('pupil-search').focus(); return; }
    if (!/^[A-Za-z0-9_-]{1,32}$/.test(body.cab_id)) { say(message, 'Name the cab: 1-32 letters, digits, - or _.'); $('cab').focus(); return; }
    if ($('truck').value) body.truck = $('truck').value;
    if ($('load-none').checked) body.load = null;
    if ($('load-custom').checked) body.load = { mass_kg: Number($('mass').value), cog_height_m: Number($('height').value), lateral_m: Number($('lateral').value) };
    if ($('limit').value) body.time_limit_s = Number($('limit').value);
    if (body.mode === 'training') body.aids = [...document.querySelectorAll('#aids-set input:checked')].map((i) => i.value);
    try {
      const s = await api('POST', '/sessions', body);
      session = s.id;
      $('started').hidden = false;
      $('started-heading').textContent = `Session ${s.id}`;
      $('started-link').href = `session.html?id=${encodeURIComponent(s.id)}`;
      $('start-button').disabled = true;
      follow();
    } catch (e) {
      say(message, describeError(e));
    }
  });

  async function init() {
    try {
      // The pupil typed and picked from the server's matches (a school has hundreds).
      await FL_LIST.pupilPicker($('pupil-search'), $('pupil'), $('pupil-options'),
        (p) => { $('pupil-about').textContent = p ? `${p.name}${p.group ? `, ${p.group}` : ''}` : ''; }, param('pupil'));
      const [sc, tr, fleet] = await Promise.all([api('GET', '/scenarios'), api('GET', '/trucks'), api('GET', '/fleet')]);
      scenarios = sc;
      trucks = tr;
      const group = (label, keep) => el('optgroup', { label }, sc.filter(keep).map((s) => el('option', { value: s.name }, s.exam_title ? `${s.name}: ${s.exam_title}` : s.name)));
      $('scenario').append(group('Exam courses (practical exams and training)', (s) => s.exam_course),
        group('Warehouse and yard scenarios (training)', (s) => s.kind === 'scenario' && !s.exam_course),
        group("The paper's manoeuvres (training and study)", (s) => s.kind === 'manoeuvre'));
      $('truck').append(el('option', { value: '' }, 'as the scenario sets it'), ...tr.map((t) => el('option', { value: t.name }, t.title)));
      const cabs = fleet.cabs;
      // A cab typed that the fleet has never seen is said at once (under DDS Security the server
      // refuses it; without, its session waits for that cab to connect).
      $('cab').addEventListener('change', () => {
        const typed = $('cab').value.trim();
        $('cab-warning').textContent = typed && !cabs.some((c) => c.id === typed)
          ? `No cab called ${typed} has connected to this server: check the name.` : '';
      });
      $('cab-list').append(...cabs.map((c) => el('option', { value: c.id }, `${c.id}: ${c.online ? 'online' : 'offline'}${c.session ? ', busy' : ''}`)));
      const free = cabs.find((c) => c.online && !c.session);
      if (free) $('cab').value = free.id;
      $('cab-about').textContent = cabs.length ? `Online now: ${cabs.filter((c) => c.online).map((c) => c.id + (c.session ? ' (busy)' : '')).join(', ') || 'none'}.`
                                               : 'No cab has announced itself yet; a session waits for its cab to connect.';
      if (me.role === 'instructor') {
        $('mode').querySelector('option[value="exam"]').disabled = true;
        $('mode-about').textContent = 'Practical exams are started by an examiner or an administrator.';
      }
    } catch (e) {
      say(message, describeError(e));
    }
    $('scenario').addEventListener('change', () => { aboutScenario(); aboutTruck(); });
    // An exam has no learning aids and runs only on an exam course as it is laid out (its truck
    // and loads): the aids are hidden (ticked and greyed, they read as if the exam had them), the
    // other choices greyed out rather than refused after the click.
    const aids = () => {
      const exam = $('mode').value === 'exam';
      $('aids-set').disabled = exam;
      $('aids-set').hidden = exam;
      $('aids-exam').hidden = !exam;
      for (const o of $('scenario').querySelectorAll('option')) {
        const s = scenarios.find((x) => x.name === o.value);
        o.disabled = exam && !(s && s.exam_course);
      }
      if (exam && $('scenario').selectedOptions[0]?.disabled) {
        const first = [...$('scenario').querySelectorAll('option')].find((o) => !o.disabled);
        if (first) $('scenario').value = first.value;
        aboutScenario();
        aboutTruck();
      }
      for (const id of ['truck', 'load-scenario', 'load-none', 'load-custom']) if ($(id)) $(id).disabled = exam;
      if (exam) { $('truck').value = ''; if ($('load-scenario')) $('load-scenario').checked = true; customLoad(); }
    };
    $('mode').addEventListener('change', aids);
    aids();
    $('truck').addEventListener('change', () => { $('truck').dataset.touched = '1'; aboutTruck(); });
    for (const r of document.querySelectorAll('input[name="load"]')) r.addEventListener('change', customLoad);
    aboutScenario();
    aboutTruck();
    customLoad();
  }
  init();
})();
