// What a certificate says, drawn the same way on the printable certificate (certificate.html) and
// on the verification page anyone can open (verify.html): the record the server signed, its
// status, and a QR code that opens its verification (qrcode-generator, from npm, in vendor/). In
// the certificate's language (the record's "language"): the "certificate" messages.
'use strict';
const CertificateView = (() => {
  const { el, clear, day, num, pct, t, useLanguage } = FL;
  const STATUS_CLASS = { valid: 'passed', revoked: 'not-passed', does_not_verify: 'not-passed', not_found: 'not-passed' };

  // The page in the certificate's language (a record from before languages were kept: English).
  const inLanguageOf = (c) => (c ? useLanguage(c.language || 'en', ['certificate']) : Promise.resolve());

  function fact(dl, term, ...value) { dl.append(el('dt', {}, term), el('dd', {}, ...value)); }
  const person = (p) => (p ? p.name || p.username || '' : '');

  // The status as a banner: its word, what it means, and what went wrong or who revoked it and why.
  function status(node, v) {
    const known = v.status in STATUS_CLASS;
    const cls = STATUS_CLASS[v.status] || 'not-passed';
    const word = known ? t(`certificate:status.${v.status}.word`) : v.status;
    const meaning = known ? t(`certificate:status.${v.status}.meaning`) : '';
    const out = [el('p', { class: 'verdict', id: 'verdict', 'data-status': v.status }, el('span', { class: `badge ${cls}` }, word), ' ', meaning)];
    if (v.revocation)
      out.push(el('p', { id: 'revocation' },
        t('certificate:status.revocation', { date: day(v.revocation.at), by: v.revocation.by, reason: v.revocation.reason })));
    if (v.problems && v.problems.length) out.push(el('ul', { id: 'problems', class: 'small' }, v.problems.map((p) => el('li', {}, p))));
    clear(node).append(...out);
  }

  // The certificate's facts: who, which school, the exams that justify it and who examined them,
  // the licence, and when the operator must be evaluated again.
  function facts(dl, c) {
    clear(dl);
    fact(dl, t('certificate:facts.number'), el('strong', { id: 'cert-number' }, c.number));
    fact(dl, t('certificate:facts.school'), el('span', { id: 'cert-school' }, c.school));
    fact(dl, t('certificate:facts.operator'), el('strong', { id: 'cert-name' }, c.pupil.name));
    const th = c.theory;
    if (th) fact(dl, t('certificate:facts.theory'),
                 t('certificate:facts.theory_passed', { date: day(th.taken_at), correct: th.correct ?? '?', total: th.total ?? '?', score: pct(th.score) }),
                 th.pass_mark !== null && th.pass_mark !== undefined ? t('certificate:facts.theory_pass_mark', { mark: pct(th.pass_mark) }) : ')',
                 el('div', { class: 'small' }, t('certificate:facts.supervised_by', { name: person(th.examiner) })));
    for (const p of c.practical || []) {
      fact(dl, t('certificate:facts.practical'), el('span', { class: 'practical', 'data-session': p.session },
        t('certificate:facts.practical_passed', { date: day(p.taken_at), mark: num(p.score), course: p.course })),
        p.truck ? el('div', { class: 'small' }, t('certificate:facts.truck', { truck: p.truck.title + (p.truck.osha_class ? `, ${p.truck.osha_class}` : '') })) : '',
        el('div', { class: 'small' }, t('certificate:facts.examiner'), el('span', { class: 'examiner' }, person(p.examiner)),
           t('certificate:facts.session', { session: p.session })));
    }
    // Only what the record holds: each training session counted, with its date and mark, and no
    // word of training when the record lists none.
    const trained = (c.training && c.training.list) || [];
    if (trained.length)
      fact(dl, t('certificate:facts.training'), t('certificate:facts.training_sessions', { count: trained.length }) +
                           (c.training.truck_class ? t('certificate:facts.training_on', { class: c.training.truck_class }) : '') + ':',
           el('ul', { id: 'cert-training', class: 'small' },
              trained.map((s) => el('li', {}, t('certificate:facts.training_item',
                { date: day(s.at), scenario: s.title || s.scenario.replace(/_/g, ' '), mark: num(s.mark) })))));
    fact(dl, t('certificate:facts.evaluated'), day(c.evaluated_at));
    fact(dl, t('certificate:facts.licence'), t('certificate:facts.licence_by', { date: day(c.licence.issued_at), name: person(c.licence.issued_by) }));
    fact(dl, t('certificate:facts.due'), el('strong', { id: 'cert-due' }, day(c.reevaluation_due)),
         el('div', { class: 'small' }, t('certificate:facts.due_rule')));
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

  return { status, facts, verifyUrl, qr, inLanguageOf };
})();
