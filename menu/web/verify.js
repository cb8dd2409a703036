// The verification page, open to anyone: GET /api/certificates/{number} (no login) says whether the
// certificate is valid (the record the school's server signed, each exam it cites the one recorded
// with its evidence verified), revoked, or does not verify; or that no certificate has the number.
// In the certificate's language once found; before, in ?lang=, the login's or the browser's.
'use strict';
(() => {
  const { api, el, clear, say, describeError, param, login, topBar, useLanguage, preferredLanguage } = FL;
  const $ = (x) => document.getElementById(x);
  if (login()) topBar(login());

  async function verify(number) {
    $('number').value = number;
    clear($('message'));
    $('result').hidden = true;
    try {
      const v = await api('GET', `/certificates/${encodeURIComponent(number.trim())}`);
      await CertificateView.inLanguageOf(v.certificate);
      CertificateView.status($('status'), v);
      if (v.certificate) CertificateView.facts($('cert-facts'), v.certificate);
      else clear($('cert-facts'));
      clear($('checks')).append(...v.checks.map((c) => el('li', {}, c)));
      $('result').hidden = false;
    } catch (e) {
      if (e.code === 'not_found') {
        CertificateView.status($('status'), { status: 'not_found', problems: [e.message] });
        clear($('cert-facts'));
        clear($('checks'));
        $('result').hidden = false;
      } else {
        say($('message'), describeError(e));
      }
    }
  }

  $('lookup').addEventListener('submit', (ev) => {
    ev.preventDefault();
    const number = $('number').value.trim();
    history.replaceState(null, '', `verify.html?number=${encodeURIComponent(number)}`);
    verify(number);
  });
  (async () => {
    await useLanguage(preferredLanguage(), ['certificate']);
    const number = param('number');
    if (number) verify(number);
  })();
})();
