// The interactive API page: renders /v1/openapi.json (the document the router is built from)
// and lets the reader send a request with a token. No external code.

const METHODS = ['get', 'post', 'put', 'patch', 'delete'];

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else node.setAttribute(k, v);
  }
  for (const c of children) node.append(c);
  return node;
}

function schemaName(schema) {
  if (!schema) return '';
  if (schema.$ref) return schema.$ref.split('/').pop();
  if (schema.type === 'array') return `[${schemaName(schema.items)}]`;
  return schema.type || 'object';
}

function tokenInput() {
  return document.getElementById('doc-token-input');
}

function operation(path, method, op) {
  const params = op.parameters || [];
  const details = el('details', { class: 'op' });
  const security = op.security ? Object.keys(op.security[0] || {}).join(', ') : 'public';
  details.append(el('summary', {},
    el('span', { class: `method ${method}` }, method.toUpperCase()), ' ',
    el('code', {}, path), ' ', el('span', { class: 'muted' }, security)));
  if (op.description || op.summary) {
    details.append(el('p', {}, op.summary || ''), el('p', {}, op.description || ''));
  }
  const form = el('form', { class: 'try' });
  const inputs = {};
  for (const p of params) {
    const input = el('input', { name: p.name, placeholder: schemaName(p.schema) });
    inputs[p.name] = [p, input];
    form.append(el('label', {}, `${p.name} (${p.in}${p.required ? ', required' : ''}) `, input));
  }
  let body = null;
  const content = op.requestBody && op.requestBody.content;
  if (content) {
    const type = Object.keys(content)[0];
    body = el('textarea', { rows: '4', placeholder: `${type}: ${schemaName(content[type].schema)}` });
    form.append(el('label', {}, 'body ', body));
  }
  const responses = el('ul');
  for (const [status, r] of Object.entries(op.responses || {})) {
    const c = r.content ? Object.values(r.content)[0] : null;
    responses.append(el('li', {}, `${status} ${r.description || ''} ${c ? schemaName(c.schema) : ''}`));
  }
  const out = el('pre', { class: 'out' });
  form.append(el('button', { type: 'submit' }, 'Try it'));
  form.addEventListener('submit', async (e) => {
    e.preventDefault();
    let url = path;
    const query = new URLSearchParams();
    const headers = {};
    for (const [name, [p, input]] of Object.entries(inputs)) {
      if (!input.value) continue;
      if (p.in === 'path') url = url.replace(`{${name}}`, encodeURIComponent(input.value));
      else if (p.in === 'query') query.set(name, input.value);
      else if (p.in === 'header') headers[name] = input.value;
    }
    if (query.size) url += `?${query}`;
    if (tokenInput().value) headers.Authorization = `Bearer ${tokenInput().value}`;
    const init = { method: method.toUpperCase(), headers };
    if (body && body.value) {
      init.body = body.value;
      headers['Content-Type'] = Object.keys(content)[0];
    }
    out.textContent = '…';
    try {
      const r = await fetch(url, init);
      const type = r.headers.get('content-type') || '';
      const text = type.startsWith('image/') || type.includes('octet') || type.includes('exr')
        ? `(${type}, ${(await r.arrayBuffer()).byteLength} bytes)`
        : (await r.text()).slice(0, 20000);
      out.textContent = `${r.status} ${r.statusText}\n${text}`;
    } catch (err) {
      out.textContent = String(err);
    }
  });
  details.append(el('h4', {}, 'Responses'), responses, form, out);
  return details;
}

async function main() {
  tokenInput().value = sessionStorage.getItem('spindle-token') || '';
  const info = document.getElementById('doc-info');
  const r = await fetch('/v1/openapi.json');
  if (!r.ok) {
    info.textContent = `GET /v1/openapi.json: ${r.status}`;
    return;
  }
  const doc = await r.json();
  info.replaceChildren(el('strong', {}, `${doc.info.title} ${doc.info.version}`), ' — ', doc.info.description || '');
  const list = document.getElementById('operations');
  for (const [path, item] of Object.entries(doc.paths).sort()) {
    for (const method of METHODS) {
      if (item[method]) list.append(operation(path, method, item[method]));
    }
  }
}

main();
