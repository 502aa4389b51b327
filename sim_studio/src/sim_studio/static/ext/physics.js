// The world's pace (sim_studio/physics.py): the real-time factor the world aims at, beside
// the measured one in the header; Enter (or leaving the field) sets it through
// /gazebo/set_physics_properties. 0: as fast as the world can.
'use strict';
(function () {
  const studio = window.studio;
  const rtf = document.getElementById('rtf');
  const span = document.createElement('span');
  span.title = 'the real-time factor the world aims at (0: as fast as it can); Enter sets it';
  span.innerHTML = 'aim <input data-testid="rtf-aim" type="number" min="0" step="0.25" ' +
                   'style="width: 4.5em">';
  rtf.parentNode.after(span);
  const input = span.querySelector('input');
  let shown = null;
  function show(rep) {
    if (rep && rep.ok) {
      shown = rep.real_time_factor;
      input.value = parseFloat(shown.toPrecision(6));
    }
  }
  studio.on('hello', () => studio.send({op: 'physics'}).then(show));
  function set() {
    const v = parseFloat(input.value);
    if (!(v >= 0) || v === shown) return;
    studio.send({op: 'physics', real_time_factor: v}).then((rep) => {
      if (!rep.ok) { studio.showError(rep); if (shown !== null) input.value = shown; return; }
      show(rep);
    });
  }
  input.addEventListener('keydown', (e) => { if (e.key === 'Enter') set(); });
  input.addEventListener('change', set);
})();
