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
  any tree (``tree``, ``tree_kernels``, ``tree_steps``, ``tree_events``, ``tree_impacts``, ``whole_run``).
* how the compiled kernels are declared and cached (``jit``: one key of robodyn's version and the
  kernels' sources) and compiled ahead (``warmup``, ``robodyn warmup``).
"""
