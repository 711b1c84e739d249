"""Simulation: what is integrated and how a run goes.

* the step's stages: ``springs`` (positions), ``actuation`` (torque, clamped at the efforts),
  ``smooth`` (the backend's M^-1 (tau - C v - G)), ``limits`` (joint stops: impacts, holding)
  and ``loops`` (closed chains, Pinocchio's constraint dynamics), assembled by ``system``;
* what the user asks for: ``constraints`` (the frozen spec), ``couplings`` (mimic joints);
* a run: ``events`` (impacts and releases located inside a step), ``run`` (the stepping loop),
  ``simulation`` (:func:`robodyn.simulate`), ``energy`` and ``trajectory`` (the books);
* what a run is warned of before it starts: ``stiffness`` (Coulomb friction too stiff for the
  method's step);
* many states at once (``batch``), the compiled closed forms (``fast``) and the compiled path for
  any tree (``tree`` and ``whole_run``, handing the run to :mod:`robodyn.engine.tree`).
* the compiled kernels compiled ahead (``warmup``, ``robodyn warmup``; declared and cached by
  :mod:`robodyn.engine.jit`).
"""
