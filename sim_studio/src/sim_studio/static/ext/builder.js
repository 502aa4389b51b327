// The device builder (sim_studio/builder.py): every plugin's declared parameters with the
// phone's values, grouped by plugin; saving writes a URDF (op save_device), each bad value
// named at its field by the world's own checks.
'use strict';
(function () {
  const studio = window.studio;
  const panel = studio.panel('device builder', 'builder');
  panel.id = 'builder';
  panel.innerHTML =
    '<div class="row"><button data-testid="builder-load">load the phone\'s parameters</button> ' +
    '<input data-testid="builder-filter" placeholder="filter: parameter or plugin"></div>' +
    '<div data-testid="builder-form" class="groups"></div>' +
    '<div class="row"><input data-testid="builder-path" placeholder="file to write (.urdf)" ' +
    'value="my_phone.urdf"> <button data-testid="builder-save">save</button></div>' +
    '<div data-testid="builder-status" class="status"></div>';
  const q = (id) => panel.querySelector('[data-testid="' + id + '"]');
  const form = q('builder-form'), status = q('builder-status');
  studio.builder = {groups: null};

  function el(tag, props, children) {
    const e = document.createElement(tag);
    Object.assign(e, props || {});
    for (const c of children || []) e.append(c);
    return e;
  }

  // a group's rows are made when it is first opened (the phone has ~470 parameters: the
  // column stays light while the 3D view draws)
  function render(groups) {
    form.textContent = '';
    for (const g of groups) {
      const d = el('details');
      d.dataset.group = g.key;
      const sum = el('summary', {textContent: g.key + ' '});
      sum.append(el('small', {textContent: g.filename + (g.link ? ' on ' + g.link : '') +
                                           ' (' + g.fields.length + ')'}));
      d.append(sum, el('div', {className: 'doc', textContent: g.doc || ''}));
      d.addEventListener('toggle', () => { if (d.open) rows(d, g); });
      form.append(d);
    }
    applyFilter();
  }

  function rows(d, g) {
    if (d.querySelector('table')) return;
    const table = el('table');
    for (const f of g.fields) {
      const tr = el('tr');
      tr.dataset.key = f.key;
      tr.dataset.name = f.name.toLowerCase() + ' ' + g.key.toLowerCase();
      let input;
      if (f.choices) {
        input = el('select');
        for (const c of f.choices) input.append(el('option', {value: c, textContent: c}));
        if (!f.choices.includes(f.value)) {
          input.append(el('option', {value: f.value, textContent: f.value}));
        }
      } else {
        input = el('input', {type: 'text', spellcheck: false});
      }
      input.value = f.value;
      input.dataset.key = f.key;
      input.dataset.orig = f.value;
      input.title = 'must be ' + f.must + (f.doc ? ' - ' + f.doc : '') +
        (f.given ? '' : ' (not given: the default ' + (f.default || 'none') + ')') +
        (f.also.length ? ' (also given: ' + f.also.join(', ') + ')' : '');
      input.oninput = input.onchange = () => {
        tr.classList.toggle('changed', input.value !== input.dataset.orig);
      };
      const name = el('td', {className: 'name' + (f.given ? ' given' : ''),
                             textContent: f.name});
      const err = el('div', {className: 'err'});
      err.dataset.testid = 'builder-error';
      err.dataset.key = f.key;
      tr.append(name, el('td', {}, [input, err]),
                el('td', {className: 'unit', textContent: f.unit || ''}));
      table.append(tr);
    }
    d.append(table);
    filterRows(d);
  }

  function filterRows(d) {
    const t = q('builder-filter').value.trim().toLowerCase();
    for (const tr of d.querySelectorAll('tr')) {
      tr.hidden = !!t && !tr.dataset.name.includes(t) && !tr.classList.contains('bad');
    }
  }

  function applyFilter() {
    const t = q('builder-filter').value.trim().toLowerCase();
    const groups = studio.builder.groups || [];
    for (const d of form.querySelectorAll('details')) {
      const g = groups.find((x) => x.key === d.dataset.group);
      if (t && g) {
        d.open = g.fields.some((f) => (f.name.toLowerCase() + ' ' + g.key.toLowerCase())
          .includes(t));
        if (d.open) rows(d, g);
      }
      filterRows(d);
    }
  }
  q('builder-filter').oninput = applyFilter;

  q('builder-load').onclick = () => {
    status.textContent = 'reading the description...';
    studio.send({op: 'device_params'}).then((rep) => {
      if (!rep.ok) { status.textContent = rep.error; return; }
      studio.builder.groups = rep.groups;
      render(rep.groups);
      studio.builder.loaded = (studio.builder.loaded || 0) + 1;
      const n = rep.groups.reduce((a, g) => a + g.fields.length, 0);
      status.textContent = rep.groups.length + ' plugins, ' + n + ' parameters of ' +
        rep.model + ' (' + rep.param + ')';
    });
  };

  q('builder-save').onclick = () => {
    const values = {};
    for (const i of form.querySelectorAll('input[data-key], select[data-key]')) {
      if (i.value !== i.dataset.orig) values[i.dataset.key] = i.value;
    }
    for (const e of form.querySelectorAll('.err')) e.textContent = '';
    for (const tr of form.querySelectorAll('tr.bad')) tr.classList.remove('bad');
    status.textContent = 'checking...';
    studio.send({op: 'save_device', path: q('builder-path').value, values: values})
      .then((rep) => {
        studio.builder.saves = (studio.builder.saves || 0) + 1;
        studio.builder.lastSave = rep;
        if (rep.ok) {
          status.className = 'status ok';
          status.textContent = 'written ' + rep.path + ' (' + rep.changed.length +
            ' changed); roslaunch mobile_device_sim office.launch phone_model:=' + rep.path;
          for (const i of form.querySelectorAll('input[data-key], select[data-key]')) {
            i.dataset.orig = i.value;
            i.closest('tr').classList.remove('changed');
          }
          return;
        }
        status.className = 'status bad';
        const errors = rep.errors || {};
        const keys = Object.keys(errors);
        status.textContent = keys.length || (rep.problems || []).length ?
          keys.length + ' bad value(s), nothing written' +
          ((rep.problems || []).length ? '\n' + rep.problems.join('\n') : '') : rep.error;
        for (const k of keys) {
          const group = k.slice(0, k.lastIndexOf('/'));
          const d = form.querySelector('details[data-group="' + CSS.escape(group) + '"]');
          const g = (studio.builder.groups || []).find((x) => x.key === group);
          if (d && g) { rows(d, g); d.open = true; }
          const e = form.querySelector('.err[data-key="' + CSS.escape(k) + '"]');
          if (!e) { status.textContent += '\n' + errors[k]; continue; }
          e.textContent = errors[k];
          e.closest('tr').classList.add('bad');
          e.closest('tr').hidden = false;
          e.closest('details').open = true;
        }
      });
  };
})();
