// Live images of any image topic (sim_studio/images.py): the flycam's at first when the
// world has one, or any other sensor_msgs/Image topic picked from the list.
'use strict';
(function () {
  const studio = window.studio;
  const panel = studio.panel('live images', 'images');
  panel.innerHTML =
    '<div class="row"><select data-testid="image-topic" title="a sensor_msgs/Image topic">' +
    '</select> <button data-testid="image-refresh" title="list the topics again">&#8635;</button>' +
    ' <small data-testid="image-stamp"></small></div>' +
    '<img data-testid="image-view" alt="the picked topic\'s latest image" ' +
    'style="width: 100%; display: block; min-height: 40px; background: #222">';
  const q = (id) => panel.querySelector('[data-testid="' + id + '"]');
  const select = q('image-topic'), img = q('image-view'), stamp = q('image-stamp');
  studio.images = {frames: 0, topic: null};
  function watch(topic) {
    studio.send(topic ? {op: 'watch_image', topic: topic} : {op: 'watch_image'}).then((rep) => {
      if (!rep.ok) { studio.showError(rep); select.value = studio.images.topic || ''; return; }
      studio.images.topic = rep.topic;
    });
  }
  function list(pick) {
    studio.send({op: 'image_topics'}).then((rep) => {
      if (!rep.ok) { studio.showError(rep); return; }
      const keep = studio.images.topic || pick && rep.default;
      select.innerHTML = '<option value="">(none)</option>';
      for (const t of rep.topics) {
        const o = document.createElement('option');
        o.value = o.textContent = t;
        select.appendChild(o);
      }
      select.value = keep || '';
      if (keep && keep !== studio.images.topic) watch(keep);
    });
  }
  select.addEventListener('change', () => watch(select.value));
  q('image-refresh').onclick = () => list(false);
  studio.on('hello', () => { studio.images.topic = null; list(true); });
  studio.on('image', (m) => {
    if (m.topic !== studio.images.topic) return;
    img.src = 'data:image/jpeg;base64,' + m.jpeg;
    stamp.textContent = m.t.toFixed(2) + ' s';
    studio.images.frames++;
  });
})();
