// What a certificate says, drawn the same way on the printable certificate (certificate.html) and
// on the verification page anyone can open (verify.html): the record the server signed, its
// status, and a QR code that opens its verification (qrcode-generator, from npm, in vendor/).
'use strict';
const CertificateView = (() => {
  const { el, clear, day, num, pct } = FL;
  const STATUS = {
    valid: ['passed', 'Valid', 'The school\'s server signed this certificate, and every exam it cites is the exam recorded, with its evidence verified.'],
    revoked: ['not-passed', 'Revoked', 'The school revoked this certificate.'],
    does_not_verify: ['not-passed', 'Does not verify', 'This certificate is not the one the school issued, or an exam it cites no longer verifies.'],
    not_found: ['not-passed', 'Not found', 'No certificate has this number.'],
  };

  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }
  const person = (p) => (p ? p.name || p.username || '' : '');

  // The status as a banner: its word, what it means, and what went wrong or who revoked it and why.
  function status(node, v) {
    const [cls, word, meaning] = STATUS[v.status] || ['not-passed', v.status, ''];
    const out = [el('p', { class: 'verdict', id: 'verdict', 'data-status': v.status }, el('span', { class: `badge ${cls}` }, word), ' ', meaning)];
    if (v.revocation)
      out.push(el('p', { id: 'revocation' }, `Revoked on ${day(v.revocation.at)} by ${v.revocation.by}: ${v.revocation.reason}`));
    if (v.problems && v.problems.length) out.push(el('ul', { id: 'problems', class: 'small' }, v.problems.map((p) => el('li', {}, p))));
    clear(node).append(...out);
  }

  // The certificate's facts: who, which school, the exams that justify it and who examined them,
  // the licence, and when the operator must be evaluated again.
  function facts(dl, c) {
    clear(dl);
    fact(dl, 'Certificate number', el('strong', { id: 'cert-number' }, c.number));
    fact(dl, 'School', el('span', { id: 'cert-school' }, c.school));
    fact(dl, 'Operator', el('strong', { id: 'cert-name' }, c.pupil.name));
    const t = c.theory;
    if (t) fact(dl, 'Theory exam', `passed ${day(t.taken_at)}: ${t.correct ?? '?'} of ${t.total ?? '?'} right (${pct(t.score)}`,
                t.pass_mark !== null && t.pass_mark !== undefined ? `; pass mark ${pct(t.pass_mark)})` : ')',
                el('div', { class: 'small' }, `supervised by ${person(t.examiner)}`));
    for (const p of c.practical || []) {
      fact(dl, 'Practical exam', el('span', { class: 'practical', 'data-session': p.session },
        `passed ${day(p.taken_at)}: mark ${num(p.score)} on the exam course ${p.course}`),
        p.truck ? el('div', { class: 'small' }, `truck: ${p.truck.title}${p.truck.osha_class ? `, ${p.truck.osha_class}` : ''}`) : '',
        el('div', { class: 'small' }, `examiner: `, el('span', { class: 'examiner' }, person(p.examiner)), ` (session ${p.session})`));
    }
    // Only what the record holds: each training session counted, with its date and mark, and no
    // word of training when the record lists none.
    const trained = (c.training && c.training.list) || [];
    if (trained.length)
      fact(dl, 'Training', `${trained.length} marked simulator training session${trained.length === 1 ? '' : 's'}` +
                           (c.training.truck_class ? ` on ${c.training.truck_class}` : '') + ':',
           el('ul', { id: 'cert-training', class: 'small' },
              trained.map((t) => el('li', {}, `${day(t.at)}: ${t.scenario.replace(/_/g, ' ')}, mark ${num(t.mark)} of 100`))));
    fact(dl, 'Date of evaluation', day(c.evaluated_at));
    fact(dl, 'Licence issued', `${day(c.licence.issued_at)} by ${person(c.licence.issued_by)}`);
    fact(dl, 'Re-evaluation due', el('strong', { id: 'cert-due' }, day(c.reevaluation_due)),
         el('div', { class: 'small' }, 'An evaluation of the operator\'s performance at least once every three years: 29 CFR 1910.178(l)(4)(iii).'));
  }

  // The verification page's address for a certificate: on the school's public address when the
  // server has one (--public-url), else on the address this page was opened at.
  function verifyUrl(v) {
    return v.verify_url || `${location.origin}/verify.html?number=${encodeURIComponent(v.number)}`;
  }

  // A QR code of `text` on `canvas`: 4 pixels a module, the standard's quiet zone of 4 modules.
  function qr(canvas, text) {
    const code = qrcode(0, 'M');
    code.addData(text);
    code.make();
    const n = code.getModuleCount(), scale = 4, quiet = 4;
    canvas.width = canvas.height = (n + 2 * quiet) * scale;
    const g = canvas.getContext('2d');
    g.fillStyle = '#fff';
    g.fillRect(0, 0, canvas.width, canvas.height);
    g.fillStyle = '#000';
    for (let r = 0; r < n; r++)
      for (let c = 0; c < n; c++)
        if (code.isDark(r, c)) g.fillRect((c + quiet) * scale, (r + quiet) * scale, scale, scale);
    canvas.dataset.text = text;
  }

  return { status, facts, verifyUrl, qr };
})();
