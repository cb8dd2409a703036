// The printable certificate: GET /api/pupils/{id}/certificate (the latest, made when the licence
// was issued; the server answers 409 before), with its status, its number, a QR code of its
// verification page, and for examiners and administrators its revocation.
'use strict';
(() => {
  const { api, requireLogin, say, describeError, day, param, t, useLanguage } = FL;
  const me = requireLogin();
  // ?pupil= as the pupil page links it, or ?id= as every other page names its record.
  const id = param('pupil') || param('id') || (me.role === 'pupil' ? String(me.pupil_id) : null);
  const $ = (x) => document.getElementById(x);
  $('print').addEventListener('click', () => window.print());
  $('back').href = `pupil.html?id=${encodeURIComponent(id)}`;

  // In the certificate's language, whoever opens it.
  async function show(v) {
    const c = v.certificate;
    await CertificateView.inLanguageOf(c);
    CertificateView.status($('status'), v);
    $('print').disabled = v.status !== 'valid';  // only a valid certificate is printed
    if (!c) return;
    document.title = t('certificate:page.document_title', { number: c.number, name: c.pupil.name, school: c.school });
    $('cert-school-line').textContent = c.school;
    $('statement').textContent = c.statement || '';
    CertificateView.facts($('cert-facts'), c);
    const url = CertificateView.verifyUrl(v);
    $('verify-url').textContent = url;
    CertificateView.qr($('qr'), url);
    $('issued').textContent = t('certificate:page.issued', { issued: day(c.issued_at), printed: day(new Date().toISOString()) });
    $('certificate').hidden = false;
    $('page-heading').hidden = true;  // the certificate's own heading names the page
    $('revoke-box').hidden = !(me.role === 'admin' || me.role === 'examiner') || v.status === 'revoked';
  }

  $('revoke').addEventListener('submit', async (ev) => {
    ev.preventDefault();
    try {
      const number = $('cert-number').textContent;
      await show(await api('POST', `/certificates/${encodeURIComponent(number)}/revoke`, { reason: $('revoke-reason').value }));
      say($('message'), t('certificate:page.revoked_done'), 'ok');
    } catch (e) {
      say($('message'), describeError(e));
    }
  });

  // Until a certificate is shown, the reader's language.
  async function init() {
    await useLanguage(me.language || 'en', ['certificate']);
    if (!id) { say($('message'), t('certificate:page.which_pupil')); return; }
    try {
      await show(await api('GET', `/pupils/${encodeURIComponent(id)}/certificate`));
    } catch (e) {
      say($('message'), e.code === 'not_certified' ? FL.tAround('certificate:page.none_yet', 'why', FL.english(e.message)) : describeError(e),
          e.code === 'not_certified' ? 'warn' : 'error');
      $('print').disabled = true;
    }
  }
  init();
})();
