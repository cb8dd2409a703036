// What the school's list pages share (pupils, sessions, exams): a table a page at a time with the
// total, column headers that sort (on the server, whose order the CSV keeps), and the CSV of
// the whole filtered list, every page of it, as the server streams it. Loaded after app.js.
'use strict';

const FL_LIST = (() => {
  const { api, el, clear, say, describeError, t } = FL;

  // A paged, sorted list, worded in the page's language. `opts`: path (e.g. '/pupils'), key (the
  // page's array: 'pupils', and its noun in the catalogue's lists.nouns), table, count, previous,
  // next, message, csv (a button), filters() (the query's filters as an object), row(item) (a
  // <tr>), sort and order (the server's default), page size.
  function pagedList(opts) {
    // after: the row the next page follows (keyset paging, where the server offers next_after):
    // then the offset only numbers the rows shown.
    const state = { offset: 0, sort: opts.sort, order: opts.order, asked: 0, after: null, nextAfter: null };
    const size = opts.size || 50;
    const tbody = opts.table.querySelector('tbody');

    function query(extra = {}) {
      const q = new URLSearchParams({ sort: state.sort, order: state.order });
      if (!extra.format) {  // the CSV is every page
        q.set('limit', size);
        if (state.after !== null) { q.set('after', state.after); q.set('offset', 0); } else q.set('offset', state.offset);
      }
      for (const [k, v] of Object.entries(opts.filters())) if (v !== '' && v !== null && v !== undefined) q.set(k, v);
      for (const [k, v] of Object.entries(extra)) q.set(k, v);
      return q.toString();
    }

    function headers() {
      for (const th of opts.table.querySelectorAll('thead th[data-sort]')) {
        const key = th.dataset.sort;
        const on = key === state.sort;
        th.setAttribute('aria-sort', on ? (state.order === 'asc' ? 'ascending' : 'descending') : 'none');
        let b = th.querySelector('button');
        if (!b) {
          b = el('button', { type: 'button', class: 'link sort' }, th.textContent);
          clear(th).append(b);
          b.addEventListener('click', () => {
            if (state.sort === key) state.order = state.order === 'asc' ? 'desc' : 'asc';
            else { state.sort = key; state.order = th.dataset.first || 'asc'; }
            state.offset = 0;
            state.after = null;
            load();
          });
        }
        b.dataset.arrow = on ? (state.order === 'asc' ? ' ▲' : ' ▼') : '';
        b.setAttribute('aria-label', t(on && state.order === 'asc' ? 'lists.sort_desc' : 'lists.sort_asc', { column: b.textContent }));
      }
    }

    async function load() {
      const mine = ++state.asked;
      headers();
      try {
        const page = await api('GET', `${opts.path}?${query()}`);
        if (mine !== state.asked) return;  // a later request has been sent
        const items = page[opts.key];
        if (items.length === 0 && state.offset > 0 && page.total > 0) {
          state.offset = Math.max(0, page.total - size); state.after = null; load(); return;
        }
        state.nextAfter = page.next_after ?? null;
        clear(tbody).append(...items.map(opts.row));
        const what = t(`lists.nouns.${opts.key}`, { count: page.total });
        const counted = { from: state.offset + 1, to: state.offset + items.length, count: page.total, what };
        opts.count.textContent = page.total === 0 ? t('lists.none', { what })
          : page.total_is_at_least ? t('lists.count_at_least', { ...counted, total: page.total.toLocaleString(document.documentElement.lang || 'en') })
          : t('lists.count', counted);
        opts.count.dataset.total = page.total;
        opts.previous.disabled = state.offset === 0;
        // A filter that matches more than the store counts (10,000): pages go on while they are full.
        opts.next.disabled = page.total_is_at_least ? items.length < size : state.offset + items.length >= page.total;
      } catch (e) {
        say(opts.message, describeError(e));
      }
    }

    opts.previous.addEventListener('click', () => { state.offset = Math.max(0, state.offset - size); state.after = null; load(); });
    opts.next.addEventListener('click', () => { state.offset += size; state.after = state.nextAfter; load(); });
    if (opts.csv) {
      opts.csv.addEventListener('click', async () => {
        try {
          const blob = await api('GET', `${opts.path}?${query({ format: 'csv' })}`);
          const a = el('a', { href: URL.createObjectURL(blob), download: `${opts.key}.csv` });
          document.body.append(a);
          a.click();
          a.remove();
        } catch (e) {
          say(opts.message, describeError(e));
        }
      });
    }
    // From the first page again (a filter changed).
    const reload = () => { state.offset = 0; state.after = null; load(); };
    return { load, reload };
  }

  // The local date YYYY-MM-DD of now, for "today" (the server's days are UTC: the page says so).
  function today() {
    const d = new Date();
    const p = (n) => String(n).padStart(2, '0');
    return `${d.getUTCFullYear()}-${p(d.getUTCMonth() + 1)}-${p(d.getUTCDate())}`;
  }

  // A type-ahead pupil picker: `input` (type search, with a datalist) asks the server for pupils
  // whose name or email has what is typed; the one chosen goes into `hidden` (its id) and
  // `onpick(pupil)` is told. `initial` (an id) is looked up and shown; the promise returned
  // settles once it is.
  function pupilPicker(input, hidden, list, onpick, initial) {
    let found = [];
    let asked = 0;
    const label = (p) => `${p.name}${p.email ? ` <${p.email}>` : ''} #${p.id}`;
    const pick = (p) => {
      hidden.value = p ? String(p.id) : '';
      if (p) input.value = label(p);
      if (onpick) onpick(p);
    };
    async function suggest() {
      const mine = ++asked;
      const typed = input.value.trim();
      const exact = found.find((p) => label(p) === typed);
      if (exact) { pick(exact); return; }
      hidden.value = '';
      if (onpick) onpick(null);
      try {
        const page = await api('GET', `/pupils?${new URLSearchParams({ search: typed.replace(/ <.*$/, ''), limit: 20 })}`);
        if (mine !== asked) return;
        found = page.pupils;
        clear(list).append(...found.map((p) => el('option', { value: label(p) })));
        if (found.length === 1 && typed && found[0].name.toLowerCase() === typed.toLowerCase()) pick(found[0]);
      } catch (e) {
        console.warn(e);
      }
    }
    let timer = null;
    input.addEventListener('input', () => { clearTimeout(timer); timer = setTimeout(suggest, 150); });
    input.addEventListener('change', suggest);
    if (initial) return api('GET', `/pupils/${encodeURIComponent(initial)}`).then((p) => { found = [p]; pick(p); }).catch(() => {});
    return suggest();
  }

  return { pagedList, today, pupilPicker };
})();
