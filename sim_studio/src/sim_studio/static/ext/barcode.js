// The decoded barcode of the phone camera (issue 47 part 4; sim_studio/barcode.py): under the
// camera view (data-testid="barcode") the texts the runner's own decoder finds in the
// camera's latest image (the `barcode` stream, 2 Hz, asked for with {op: 'barcode', on: true}
// at each connection), each a `barcode-code`; `no barcode`
// when there is none. In assert mode a click on a text opens a form (`barcode-form`:
// eventually or always, a window in s of sim time; empty: the whole run) whose `add`
// (`barcode-add`) makes it the runner's image expectation {topic, eventually: {barcode:
// TEXT}, window} (op expect_barcode).
'use strict';
(function () {
  const S = window.studio;
  const $ = (id) => document.getElementById(id);
  const B = S.barcode = {messages: 0, last: null};

  const box = document.createElement('div');
  box.className = 'barcode';
  box.dataset.testid = 'barcode';
  box.title = "barcodes decoded in the camera's image (the runner's decoder); in assert " +
    'mode a click expects one';
  box.textContent = 'no barcode';
  $('camera').after(box);

  const form = document.createElement('form');
  form.className = 'barcode-form';
  form.dataset.testid = 'barcode-form';
  form.hidden = true;
  form.innerHTML = 'expect <b class="what"></b><br>' +
    '<select name="mode"><option>eventually</option><option>always</option></select> ' +
    'window <input name="start" type="number" step="any" min="0" value="0"> to ' +
    '<input name="end" type="number" step="any" min="0" value="1"> s ' +
    '<button type="submit" data-testid="barcode-add">add</button> ' +
    '<button type="button" class="cancel">cancel</button>';
  box.after(form);
  form.querySelector('.cancel').onclick = () => { form.hidden = true; };

  function show(m) {
    B.messages++;
    B.last = m;
    const key = JSON.stringify([m.codes, m.error]);
    if (key === B.key) return;             // unchanged: keep the elements (a click on them)
    B.key = key;
    box.textContent = '';
    if (m.error) { box.textContent = m.error; return; }
    if (!m.codes.length) { box.textContent = 'no barcode'; return; }
    m.codes.forEach((c, i) => {
      const s = document.createElement('span');
      s.className = 'code';
      s.dataset.testid = 'barcode-code';
      s.dataset.data = c.data;
      s.dataset.topic = m.topic;
      s.title = c.type;
      s.textContent = c.data;
      if (i) box.append(' ');
      box.append(s);
    });
  }
  S.on('barcode', show);
  S.on('hello', () => S.send({op: 'barcode', on: true}));     // the stream, to this page

  box.addEventListener('click', (e) => {
    const code = e.target.closest('.code');
    if (!S.asserting || !code) return;
    form.dataset.topic = code.dataset.topic;
    form.dataset.text = code.dataset.data;
    form.querySelector('.what').textContent = code.dataset.topic + ' barcode ' +
      JSON.stringify(code.dataset.data);
    form.hidden = false;
  });
  // assert mode off: the form goes (studio.js toggles S.asserting on the same click)
  $('assert').addEventListener('click', () => { if (!S.asserting) form.hidden = true; });

  form.onsubmit = (e) => {
    e.preventDefault();
    const el = form.elements;
    const cmd = {op: 'expect_barcode', topic: form.dataset.topic, text: form.dataset.text,
                 mode: el.mode.value};
    if (el.start.value !== '' || el.end.value !== '') {
      cmd.start = parseFloat(el.start.value);
      cmd.end = parseFloat(el.end.value);
    }
    S.send(cmd).then((rep) => {
      S.showError(rep);
      if (rep.ok) {
        $('yaml').value = rep.yaml;
        form.hidden = true;
      }
    });
  };
})();
