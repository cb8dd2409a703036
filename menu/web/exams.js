// The exams page: GET /api/exams, theory and practical, filtered by kind, dates, result and pupil,
// sorted by a column, a page at a time with the total, and the same list as CSV (theory scores
// and practical marks in their own columns).
'use strict';
(() => {
  const { el, requireLogin, dateTime, num, pct, t } = FL;
  requireLogin(FL.STAFF);
  const $ = (id) => document.getElementById(id);
  const list = FL_LIST.pagedList({
    path: '/exams', key: 'exams', table: $('exams'), count: $('count'), previous: $('previous'),
    next: $('next'), message: $('message'), csv: $('csv'), sort: 'taken_at', order: 'desc',
    filters: () => ({ kind: $('kind').value, from: $('from').value, to: $('to').value, result: $('result').value,
                      search: $('search').value.trim() }),
    row: (x) => el('tr', { 'data-exam': x.id },
      el('td', {}, x.session ? el('a', { href: `session.html?id=${encodeURIComponent(x.session)}` }, dateTime(x.taken_at)) : dateTime(x.taken_at)),
      el('th', { scope: 'row' }, el('a', { href: `pupil.html?id=${encodeURIComponent(x.pupil_id)}` }, x.pupil_name)),
      el('td', {}, t(`kind.${x.kind}`)), el('td', { class: 'num' }, x.kind === 'theory' ? pct(x.score) : ''),
      el('td', { class: 'num' }, x.kind === 'practical' ? num(x.score, 1) : ''),
      el('td', {}, el('span', { class: `badge ${x.passed ? 'passed' : 'not-passed'}` }, x.passed ? t('passed') : t('not_passed'))),
      el('td', {}, x.examiner ? x.examiner.name || x.examiner.username : ''),
      el('td', { class: 'num' }, x.corrections || '')),
  });
  let timer = null;
  $('search').addEventListener('input', () => { clearTimeout(timer); timer = setTimeout(list.reload, 200); });
  for (const id of ['kind', 'from', 'to', 'result']) $(id).addEventListener('change', list.reload);
  $('filters').addEventListener('submit', (ev) => { ev.preventDefault(); list.reload(); });
  FL.wordPage('exams.title').then(list.load);
})();
