"""The whole arm: a multi-joint log and the robot's URDF in, every joint's friction out.

:mod:`adaptive_ff.arm.robot` reads the URDF with Pinocchio (the ``[arm]`` extra: ``pip install -e '.[arm]'``)
and reduces its joint-torque regressor to base parameters; :mod:`adaptive_ff.arm.arm_log` reads the log and
differentiates it; :mod:`adaptive_ff.arm.fit` identifies the rigid body and each joint's friction together
(:func:`adaptive_ff.arm.fit.identify_arm`, result :class:`adaptive_ff.arm.result.ArmIdentification`);
:mod:`adaptive_ff.arm.simulate` simulates an arm with a lagged Stribeck friction per joint and writes its log.
"""
