// The scenario editor (sim_studio/editor.py): CodeMirror 5 (Debian's libjs-codemirror, at
// /codemirror/) over the scenario textarea, with YAML highlighting, undo / redo (buttons,
// Ctrl-Z, Ctrl-Y, Shift-Ctrl-Z), the validator's FILE:LINE problems as marks on their lines
// while you type, and open / save / merge recording of a scenario file.
// The textarea (data-testid="scenario-yaml") stays the source of truth: every change of the
// editor is saved into it at once (and announced with an 'input' event), and a value set on
// it by a script (the recording, assert mode) is shown in the editor as an undoable change.
'use strict';
(function () {
  const S = window.studio;
  const $ = (id) => document.getElementById(id);
  const ta = $('yaml');
  const ed = S.editor = {cm: null, ready: false, failed: null, file: null, problems: [],
                         marks: [], checks: 0, gen: 0};
  if (!ta) return;

  // -- the toolbar above the editor ---------------------------------------------------------
  const bar = document.createElement('div');
  bar.id = 'ed-bar';
  bar.dataset.testid = 'editor-bar';
  bar.innerHTML = `
    <div class="ed-row"><input id="ed-path" data-testid="scenario-path" spellcheck="false"
      placeholder="scenario file (.yaml), on the studio's machine"><button id="ed-open"
      data-testid="scenario-open" title="read the file into the editor">open</button><button
      id="ed-save" data-testid="scenario-save" title="write the editor's text to the file, as typed (Ctrl-S)">save</button></div>
    <div class="ed-row"><button id="ed-undo" data-testid="editor-undo" title="Ctrl-Z">undo</button><button
      id="ed-redo" data-testid="editor-redo" title="Ctrl-Y, Shift-Ctrl-Z">redo</button><button
      id="ed-merge" data-testid="scenario-merge"
      title="the recording's actions and expectations appended to the opened file's text (its comments and formatting kept)">merge recording</button>
      <span id="ed-dirty" data-testid="editor-dirty"></span></div>
    <div id="ed-msg" data-testid="scenario-file-status"></div>`;
  ta.parentNode.insertBefore(bar, ta);

  function say(text, bad) {
    $('ed-msg').textContent = text;
    $('ed-msg').className = bad ? 'bad' : '';
  }

  // -- the textarea as the source of truth ----------------------------------------------------
  const proto = Object.getOwnPropertyDescriptor(HTMLTextAreaElement.prototype, 'value');
  Object.defineProperty(ta, 'value', {
    configurable: true,
    get() { return proto.get.call(ta); },
    set(v) {
      proto.set.call(ta, v);
      const cm = ed.cm;
      if (cm && cm.getValue() !== proto.get.call(ta)) cm.setValue(proto.get.call(ta));
    },
  });
  ed.getValue = () => ta.value;
  ed.setValue = (text) => { ta.value = text; if (!ed.cm) check(); };

  // -- the validator's problems as marks --------------------------------------------------------
  let timer = null;
  function schedule() {
    clearTimeout(timer);
    timer = setTimeout(check, 250);
  }
  function check() {
    const gen = ++ed.gen, text = ta.value;
    if (!text.trim()) { show([], text); return; }          // nothing to check
    S.send({op: 'check', yaml: text}).then((rep) => {
      if (gen !== ed.gen || !rep.ok) return;      // typed on since: a newer check comes
      ed.checks++;
      show(rep.problems, text);
    });
  }
  function lineOf(p) {
    const m = /^.*?:(\d+): /.exec(p);
    return m ? parseInt(m[1], 10) : 1;
  }
  function show(problems, text) {
    ed.problems = problems;
    ed.checked = text;
    const cm = ed.cm;
    if (!cm) return;
    cm.operation(() => {
      cm.clearGutter('ed-problems');
      for (const h of ed.handles || []) cm.removeLineClass(h, 'background', 'ed-error-line');
      ed.handles = [];
      const at = {};
      for (const p of problems) {
        const n = Math.min(Math.max(lineOf(p), 1), cm.lineCount());
        (at[n] = at[n] || []).push(p);
      }
      ed.marks = Object.keys(at).map(Number).sort((a, b) => a - b)
        .map((n) => ({line: n, problems: at[n]}));
      for (const m of ed.marks) {
        const el = document.createElement('span');
        el.className = 'ed-mark';
        el.dataset.testid = 'editor-problem';
        el.dataset.line = m.line;
        el.title = m.problems.join('\n');
        el.textContent = '\u25cf';
        cm.setGutterMarker(m.line - 1, 'ed-problems', el);
        ed.handles.push(cm.addLineClass(m.line - 1, 'background', 'ed-error-line'));
      }
    });
  }

  // -- CodeMirror, loaded once the page has drawn its first frame -----------------------------
  function css(href) {
    const l = document.createElement('link');
    l.rel = 'stylesheet';
    l.href = href;
    document.head.appendChild(l);
  }
  function script(src) {
    return new Promise((resolve, reject) => {
      const s = document.createElement('script');
      s.src = src;
      s.onload = resolve;
      s.onerror = () => reject(new Error('cannot load ' + src));
      document.head.appendChild(s);
    });
  }
  function load() {
    css('/codemirror/lib/codemirror.css');
    script('/codemirror/lib/codemirror.js')
      .then(() => script('/codemirror/mode/yaml/yaml.js'))
      .then(start)
      .catch((e) => {
        ed.failed = String(e);
        say('no editor component (' + e.message + '): the plain text box is used', true);
        ta.addEventListener('input', schedule);
      });
  }
  // after the 3D view's first frame: its 400 kB must not hold the first frame back
  let loading = false;
  const later = () => { if (!loading) { loading = true; load(); } };
  S.onFrame(() => { if (S.firstFrameAt !== null) setTimeout(later, 0); });
  setTimeout(later, 10000);              // a world that never shows: the editor all the same

  function start() {
    const cm = ed.cm = CodeMirror.fromTextArea(ta, {
      mode: 'yaml', lineNumbers: true, gutters: ['ed-problems', 'CodeMirror-linenumbers'],
      indentUnit: 2, tabSize: 2, indentWithTabs: false, lineWrapping: false,
      extraKeys: {
        'Tab': (c) => c.execCommand(c.somethingSelected() ? 'indentMore' : 'insertSoftTab'),
        'Shift-Tab': 'indentLess',
        'Ctrl-Y': 'redo', 'Shift-Ctrl-Z': 'redo', 'Cmd-Y': 'redo',
        'Ctrl-S': () => save(), 'Cmd-S': () => save(),
      },
    });
    cm.getWrapperElement().dataset.testid = 'scenario-editor';
    cm.on('changes', () => {
      cm.save();                                   // the textarea holds the whole YAML
      ta.dispatchEvent(new Event('input'));        // studio.js's own check and listeners
      dirty();
      schedule();
    });
    ed.undo = () => { cm.undo(); cm.focus(); };
    ed.redo = () => { cm.redo(); cm.focus(); };
    ed.ready = true;
    if (ta.value.trim()) check();
  }

  function dirty() {
    const d = ed.file && ta.value !== ed.file.text;
    $('ed-dirty').textContent = ed.file ? (d ? 'unsaved changes to ' : '') +
      ed.file.path.split('/').pop() : '';
  }

  // -- open, save, merge ----------------------------------------------------------------------
  function problemsText(ps) {
    return ps.length ? ', ' + ps.length + ' problem' + (ps.length > 1 ? 's' : '') +
      ' (marked at their lines)' : '';
  }
  function open() {
    const path = $('ed-path').value.trim();
    if (!path) { say('open: type the path of a scenario file', true); return Promise.resolve(); }
    return S.send({op: 'open_scenario', path: path}).then((rep) => {
      if (!rep.ok) { say(rep.error, true); return rep; }
      ed.file = {path: rep.path, text: rep.yaml};
      $('ed-path').value = rep.path;
      ed.setValue(rep.yaml);
      if (ed.cm) ed.cm.clearHistory();             // undo starts at the file as opened
      show(rep.problems, rep.yaml);
      dirty();
      say('opened ' + rep.path + problemsText(rep.problems));
      return rep;
    });
  }
  function save() {
    const path = $('ed-path').value.trim();
    if (!path) { say('save: type the path of the file to write', true); return Promise.resolve(); }
    const text = ta.value;
    return S.send({op: 'save_scenario', path: path, yaml: text}).then((rep) => {
      if (!rep.ok) { say(rep.error, true); return rep; }
      ed.file = {path: rep.path, text: text};
      $('ed-path').value = rep.path;
      show(rep.problems, text);
      dirty();
      say('saved ' + rep.path + ' (' + rep.bytes + ' bytes, as typed' +
          problemsText(rep.problems) + ')', rep.problems.length > 0);
      return rep;
    });
  }
  function merge() {
    if (!ed.file) {
      say('merge: open (or save) a scenario file first; the recording is merged into it',
          true);
      return Promise.resolve();
    }
    return S.send({op: 'merge_recording', yaml: ed.file.text}).then((rep) => {
      if (!rep.ok) { say(rep.error, true); return rep; }
      ed.setValue(rep.yaml);                        // undoable (Ctrl-Z)
      say('merged ' + rep.added + ' actions and ' + rep.expects + ' expectations into ' +
          ed.file.path + ' (not saved yet)' + problemsText(rep.problems));
      return rep;
    });
  }
  ed.open = open;
  ed.save = save;
  ed.merge = merge;
  $('ed-open').onclick = open;
  $('ed-save').onclick = save;
  $('ed-merge').onclick = merge;
  $('ed-undo').onclick = () => ed.cm && ed.undo();
  $('ed-redo').onclick = () => ed.cm && ed.redo();
  $('ed-path').addEventListener('keydown', (e) => { if (e.key === 'Enter') open(); });
})();
