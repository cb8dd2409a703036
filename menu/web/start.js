// Scenario choice: pupil, scenario, truck, load and cab; POST /api/sessions starts it, and the
// page follows the session until it ends, with an abort button.
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, num, param, stateText, reasonText, t } = FL;
  const me = requireLogin(FL.STAFF);
  const $ = (id) => document.getElementById(id);
  const message = $('message');
  let scenarios = [], trucks = [], session = null;

  function loadText(l) {
    return l ? t('start.load_text', { mass: num(l.mass_kg, 0), height: num(l.cog_height_m ?? 0.6, 2) }) : t('start.no_load');
  }

  function aboutScenario() {
    const s = scenarios.find((x) => x.name === $('scenario').value);
    if (!s) return;
    const bits = [];
    // Its title in the page's language where the catalogue has it, then its description in its
    // own words (English: the scenarios' descriptions are not translated yet).
    if (document.documentElement.lang !== 'en' && FL.has(`words:scenarios.${s.name}`)) bits.push(`${t(`words:scenarios.${s.name}`)}.`);
    if (s.description) bits.push(FL.english(s.description));
    if (s.time_limit_s || s.duration_s) bits.push(t('start.time', { seconds: s.time_limit_s || s.duration_s }));
    clear($('scenario-about')).append(...bits.flatMap((b, i) => (i ? [' ', b] : [b])));
    $('load-scenario-about').textContent = `(${loadText(s.load)})`;
  }

  function aboutTruck() {
    const chosen = trucks.find((x) => x.name === $('truck').value);
    const s = scenarios.find((x) => x.name === $('scenario').value);
    const shown = chosen || trucks.find((x) => s && x.name === s.truck);
    $('truck-about').textContent = shown ? `${t('start.truck_about', { title: shown.title, capacity: shown.rated_capacity_kg, centre: num(shown.rated_load_centre_m, 1) })}${shown.osha_class ? t('start.truck_class', { class: shown.osha_class }) : ''}.` : '';
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
      $('started-status').textContent = `${t('start.status', { id: s.id, pupil: s.pupil_id, cab: s.cab_id, state: stateText(s.state) })}${s.reason ? t('start.status_reason', { reason: reasonText(s.reason) }) : ''}.`;
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
    await FL.worded();
    clear(message);
    const body = { pupil_id: Number($('pupil').value), scenario: $('scenario').value, cab_id: $('cab').value.trim(), mode: $('mode').value };
    if (!body.pupil_id) { say(message, t('start.choose_pupil')); $('pupil-search').focus(); return; }
    if (!/^[A-Za-z0-9_-]{1,32}$/.test(body.cab_id)) { say(message, t('day.name_cab')); $('cab').focus(); return; }
    if ($('truck').value) body.truck = $('truck').value;
    if ($('load-none').checked) body.load = null;
    if ($('load-custom').checked) body.load = { mass_kg: Number($('mass').value), cog_height_m: Number($('height').value), lateral_m: Number($('lateral').value) };
    if ($('limit').value) body.time_limit_s = Number($('limit').value);
    if (body.mode === 'training') body.aids = [...document.querySelectorAll('#aids-set input:checked')].map((i) => i.value);
    try {
      const s = await api('POST', '/sessions', body);
      session = s.id;
      $('started').hidden = false;
      $('started-heading').textContent = t('start.session_id', { id: s.id });
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
      trucks = tr.map(FL.truckWords);
      const group = (label, keep) => el('optgroup', { label }, sc.filter(keep).map((s) => el('option', { value: s.name }, s.exam_title ? `${s.name}: ${FL.has(`words:scenarios.${s.name}`) ? t(`words:scenarios.${s.name}`) : s.exam_title}` : s.name)));
      $('scenario').append(group(t('start.exam_courses'), (s) => s.exam_course),
        group(t('start.scenarios'), (s) => s.kind === 'scenario' && !s.exam_course),
        group(t('start.manoeuvres'), (s) => s.kind === 'manoeuvre'));
      $('truck').append(el('option', { value: '' }, t('start.as_scenario')), ...trucks.map((x) => el('option', { value: x.name }, x.title)));
      const cabs = fleet.cabs;
      // A cab typed that the fleet has never seen is said at once (under DDS Security the server
      // refuses it; without, its session waits for that cab to connect).
      $('cab').addEventListener('change', () => {
        const typed = $('cab').value.trim();
        $('cab-warning').textContent = typed && !cabs.some((c) => c.id === typed)
          ? t('start.unknown_cab', { cab: typed }) : '';
      });
      $('cab-list').append(...cabs.map((c) => el('option', { value: c.id }, t('start.cab_option', { cab: c.id, status: t(c.online ? 'fleet.online' : 'fleet.offline') }) + (c.session ? t('start.cab_busy') : ''))));
      const free = cabs.find((c) => c.online && !c.session);
      if (free) $('cab').value = free.id;
      $('cab-about').textContent = cabs.length ? t('start.online_now', { cabs: cabs.filter((c) => c.online).map((c) => c.id + (c.session ? t('start.busy') : '')).join(', ') || t('none') })
                                               : t('start.no_cab');
      if (me.role === 'instructor') {
        $('mode').querySelector('option[value="exam"]').disabled = true;
        $('mode-about').textContent = t('start.exam_by_examiner');
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
  FL.wordPage('start.title', ['certificate']).then(init);
})();
