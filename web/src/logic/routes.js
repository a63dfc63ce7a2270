// Routes: the view in the URL's hash, so a link opens the same view after a reload or a
// login ("#/scan/12", "#/sample/3", "#/scans?state=completed&text=gloss", "#/compare/4,7").

import { MAX_COMPARE } from './compare.js';

export function parseRoute(hash) {
  const h = String(hash || '').replace(/^#\/?/, '');
  const [path, query = ''] = h.split('?');
  const [view, arg] = path.split('/');
  const params = Object.fromEntries(new URLSearchParams(query));
  const id = (s) => (/^[1-9]\d{0,15}$/.test(s || '') ? Number(s) : null);
  switch (view) {
    case 'scan': case 'sample': {
      const n = id(arg);
      return n ? { view, id: n, params } : { view: view === 'scan' ? 'scans' : 'samples', params: {} };
    }
    case 'compare': {
      const ids = [...new Set(String(arg || '').split(',').map(id).filter(Boolean))].slice(0, MAX_COMPARE);
      return { view, ids, params };
    }
    case 'scans': case 'alerts': case 'samples': case 'twin': case 'run':
      return { view, params };
    default: return { view: 'run', params: {} };
  }
}

export function routeHash(route) {
  const q = new URLSearchParams(Object.entries(route.params || {}).filter(([, v]) => v !== '' && v != null)).toString();
  let path = route.view;
  if (route.view === 'scan' || route.view === 'sample') path += `/${route.id}`;
  else if (route.view === 'compare') path += `/${(route.ids || []).join(',')}`;
  return `#/${path}${q ? `?${q}` : ''}`;
}
