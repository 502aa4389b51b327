// Study mode (sim_studio/study.py): a task list for a test person, start / done / give up
// per task, undo, the sessions' CSV, and replaying a session (timed or step by step).
'use strict';
(function () {
  const studio = window.studio;
  const panel = studio.panel('study', 'study');
  panel.id = 'study';
  panel.innerHTML =
    '<textarea data-testid="study-tasks-text" rows="3" spellcheck="false" ' +
    'placeholder="tasks: one a line, or YAML / JSON (- {name, text})"></textarea>' +
    '<div class="row"><input type="file" data-testid="study-tasks-file" accept=".yaml,.yml,.json,.txt"> ' +
    '<button data-testid="study-set-tasks">set tasks</button></div>' +
    '<div class="row"><input data-testid="study-person" placeholder="test person"> ' +
    '<button data-testid="study-start">start session</button> ' +
    '<button data-testid="study-end">end session</button></div>' +
    '<div data-testid="study-current" class="current"></div>' +
    '<div class="row"><button data-testid="study-task-start">start next task</button> ' +
    '<button data-testid="study-task-finish">done</button> ' +
    '<button data-testid="study-task-give-up">give up</button> ' +
    '<button data-testid="study-undo">undo</button></div>' +
    '<ol data-testid="study-task-list"></ol>' +
    '<div data-testid="study-sessions"></div>' +
    '<div class="row"><a data-testid="study-csv" href="/api/study/csv" download="study.csv">' +
    'download CSV</a> <a href="/api/study/log.csv" download="study_log.csv">action log</a> ' +
    '<button data-testid="study-next" hidden>next command</button> ' +
    '<button data-testid="study-stop" hidden>stop replay</button></div>' +
    '<div data-testid="study-status" class="status"></div>';
  const q = (id) => panel.querySelector('[data-testid="' + id + '"]');
  const status = q('study-status');
  studio.study = {state: null};

  function say(rep) {
    status.className = 'status' + (rep.ok ? '' : ' bad');
    status.textContent = rep.ok ? '' : rep.error;
    return rep;
  }
  const send = (cmd) => studio.send(cmd).then(say);

  function show(st) {
    studio.study.state = st;
    const run = st.running;
    const list = q('study-task-list');
    list.textContent = '';
    const tasks = run ? run.tasks : st.tasks;
    tasks.forEach((t, i) => {
      const li = document.createElement('li');
      li.textContent = t.text + (t.result ? ' - ' + t.result.replace('_', ' ') : '');
      if (t.result === 'success') li.className = 'PASS';
      else if (t.result === 'gave_up') li.className = 'FAIL';
      if (run && run.current === i) li.className = 'running';
      list.append(li);
    });
    q('study-current').textContent = run ? (run.person + ': ' + (run.current === null ?
      'no task running' : 'task ' + (run.current + 1) + ' - ' + run.tasks[run.current].text))
      : 'no session';
    const ss = q('study-sessions');
    ss.textContent = '';
    for (const s of st.sessions) {
      const d = document.createElement('div');
      d.dataset.session = s.session;
      const results = s.tasks.map((t) => (t.result || '-').replace('_', ' ') +
                                  (t.errors ? ' ' + t.errors + ' err' : '') +
                                  (t.undos ? ' ' + t.undos + ' undo' : ''));
      d.append(document.createTextNode('session ' + s.session + ' ' + s.person + ': ' +
                                       results.join(', ') + ' (' + s.commands + ' commands' +
                                       (s.running ? ', running' : '') + ') '));
      for (const mode of ['timed', 'step']) {
        const b = document.createElement('button');
        b.textContent = mode === 'timed' ? 'replay' : 'step';
        b.dataset.testid = 'study-replay-' + mode;
        b.onclick = () => send({op: 'study_replay', session: s.session, mode: mode});
        d.append(b);
      }
      ss.append(d);
    }
    const r = st.replay;
    q('study-next').hidden = !(r && r.mode === 'step');
    q('study-stop').hidden = !r;
    if (r) status.textContent = 'replay of session ' + r.session + ': ' + r.i + ' / ' + r.n;
  }
  studio.on('study', show);
  const refresh = () => studio.send({op: 'study_state'}).then((rep) => { if (rep.ok) show(rep); });
  studio.on('hello', () => setTimeout(refresh, 0));

  q('study-tasks-file').onchange = (e) => {
    const f = e.target.files[0];
    if (f) f.text().then((text) => { q('study-tasks-text').value = text; });
  };
  q('study-set-tasks').onclick = () =>
    send({op: 'study_tasks', tasks_text: q('study-tasks-text').value}).then(refresh);
  q('study-start').onclick = () => send({op: 'study_start', person: q('study-person').value});
  q('study-end').onclick = () => send({op: 'study_end'});
  q('study-task-start').onclick = () => send({op: 'study_task', action: 'start'});
  q('study-task-finish').onclick = () => send({op: 'study_task', action: 'finish'});
  q('study-task-give-up').onclick = () => send({op: 'study_task', action: 'give_up'});
  q('study-undo').onclick = () => send({op: 'study_undo'}).then((rep) => {
    if (rep.ok) status.textContent = 'undone: ' + rep.undone;
  });
  q('study-next').onclick = () => send({op: 'study_next'});
  q('study-stop').onclick = () => send({op: 'study_replay', session: 0, mode: 'stop'});
})();
