// The printable certification record: GET /api/pupils/{id}/certificate, for a pupil who has
// passed the theory and the practical exam (the server answers 409 otherwise).
'use strict';
(() => {
  const { api, el, clear, requireLogin, say, describeError, day, pct, num, param } = FL;
  const me = requireLogin();
  const id = param('pupil') || (me.role === 'pupil' ? String(me.pupil_id) : null);
  const $ = (x) => document.getElementById(x);
  $('print').addEventListener('click', () => window.print());
  $('back').href = `pupil.html?id=${encodeURIComponent(id)}`;

  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }

  async function init() {
    if (!id) { say($('message'), 'Which pupil? Open this page from a pupil\'s record.'); return; }
    let c;
    try {
      c = await api('GET', `/pupils/${encodeURIComponent(id)}/certificate`);
    } catch (e) {
      say($('message'), e.code === 'not_certified' ? `No certification record yet: ${e.message}.` : describeError(e), e.code === 'not_certified' ? 'warn' : 'error');
      $('print').disabled = true;
      return;
    }
    document.title = `Certification record: ${c.pupil.name} · Forklift school`;
    $('statement').textContent = c.statement || '';
    const dl = clear($('cert-facts'));
    const t = c.theory, p = c.practical, truck = p.truck;
    fact(dl, 'Operator', el('strong', { id: 'cert-name' }, c.pupil.name));
    if (truck) fact(dl, 'Truck', truck.title, truck.osha_class ? el('div', {}, truck.osha_class) : '');
    const n = c.training.sessions;
    fact(dl, 'Training', n ? `${n} simulator training session${n === 1 ? '' : 's'}, ${day(c.training.first_at)}${n > 1 ? ` to ${day(c.training.last_at)}` : ''}`
                           : 'no simulator training sessions recorded');
    fact(dl, 'Theory exam', `passed ${day(t.taken_at)}: ${t.correct ?? '?'} of ${t.total ?? '?'} right (${pct(t.score)}; pass mark ${pct(t.pass_mark)})`);
    fact(dl, 'Practical exam', `passed ${day(p.taken_at)}: mark ${num(p.mark)}${p.scenario ? `, scenario ${p.scenario}` : ''}`,
         p.session ? [' (session ', el('span', { class: 'nowrap' }, p.session), ')'] : '');
    fact(dl, 'Evaluated by', p.examiner || 'see the signature below');
    fact(dl, 'Date of evaluation', day(p.taken_at));
    if (c.licence) fact(dl, 'Licence issued', `${day(c.licence.issued_at)} by ${c.licence.issued_by}`);
    fact(dl, 'Re-evaluation due', el('strong', { id: 'cert-due' }, day(c.reevaluation_due)),
         el('div', { class: 'small' }, 'An evaluation of the operator\'s performance at least once every three years: 29 CFR 1910.178(l)(4)(iii).'));
    $('issued').textContent = `Printed from the school's records on ${day(c.issued_at)}.`;
    $('certificate').hidden = false;
  }
  init();
})();
