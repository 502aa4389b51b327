// Models spawned or deleted after the page loaded (sim_studio/spawned.py): when the studio
// says its descriptions changed (stream 'scene_models'), or the pose stream names a model the
// page lacks or lacks one it draws, the page asks 'scene' and draws the new models (a
// model drawn as the small box of a model without description is drawn again from its
// description), removes those gone, and asks 'world_info' for the new models' icons.
'use strict';
(function () {
  const studio = window.studio;
  const S = studio.spawned = {version: 0, added: 0, replaced: 0, removed: 0, busy: false,
                              again: false, icons: false};

  // drawn as the box of a model the studio had no description of (studio.js's build)
  const isBox = (obj) => obj.children.some((c) => c.isMesh);

  function removeModel(name) {
    const obj = studio.models[name];
    if (!obj) return;
    if (studio.handle.object === obj) studio.handle.detach();
    studio.scene3d.remove(obj);
    obj.traverse((o) => { if (o.geometry) o.geometry.dispose(); });
    delete studio.models[name];
    delete studio.displays[name];
    delete studio.cameras[name];
    for (const o of document.querySelectorAll('#model option')) {
      if (o.value === name) o.remove();
    }
    const M = studio.moves;
    if (M) {
      for (const k of Object.keys(M.icons)) {
        if (M.icons[k].userData.model === name) delete M.icons[k];
      }
    }
  }

  function apply(sc, icons) {
    const names = new Set(sc.models.map((m) => m.name));
    for (const name of Object.keys(studio.models)) {
      if (!names.has(name)) { removeModel(name); S.removed++; }
    }
    const fresh = [];
    for (const m of sc.models) {
      const obj = studio.models[m.name];
      if (obj && isBox(obj) && m.links.some((ln) => ln.visuals.length)) {
        removeModel(m.name);
        S.replaced++;
      }
      if (!studio.models[m.name]) fresh.push(m);
    }
    if (fresh.length) {
      S.added += fresh.length;
      if (!studio.models[studio.selected]) studio.selected = fresh[0].name;
      studio.build({models: fresh});       // also selects studio.selected again
    } else if (!studio.models[studio.selected] && Object.keys(studio.models).length) {
      const first = Object.keys(studio.models)[0];
      document.getElementById('model').value = first;
      studio.select(first);                // the selected model was deleted
    }
    // the icons of models described since (studio.js may have drawn them already)
    const M = studio.moves;
    if ((icons || fresh.length) && M && M.addIcons) {
      M.ask({op: 'world_info'}).then((rep) => { if (rep.ok) M.addIcons(rep); });
    }
  }

  function reconcile(icons) {
    if (!studio.ready) return;
    S.icons = S.icons || !!icons;
    if (S.busy) { S.again = true; return; }
    S.busy = true;
    const want = S.icons;
    S.icons = false;
    studio.send({op: 'scene'}).then((rep) => {
      S.busy = false;
      if (rep.ok) apply(rep.scene, want);
      if (S.again) { S.again = false; reconcile(); }
    });
  }
  S.reconcile = reconcile;

  studio.on('scene_models', (m) => {
    if (m.version !== S.version) { S.version = m.version; reconcile(true); }
  });
  studio.on('poses', (m) => {
    const names = Object.keys(m.poses);
    if (!studio.ready || S.busy || !names.length) return;
    if (Object.keys(studio.models).some((n) => !(n in m.poses))) reconcile();
  });
})();
