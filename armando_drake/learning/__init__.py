"""Learned inverse kinematics: a small network from end-effector pose to joint positions.

- :mod:`~armando_drake.learning.network`: the exported network (ONNX, run by ONNX
  Runtime), its pose features, the Newton refinement and the :class:`IkNetwork` Drake
  system (pose in, joint positions out);
- :mod:`~armando_drake.learning.training`: one IK branch labelled by continuation over
  a data set of ``python -m armando_drake.dataset ik``, the network trained with
  scikit-learn, exported with skl2onnx, and its accuracy and speed against Drake's IK.

``python -m armando_drake.learn ik`` runs them (docs/learned-ik.md).
"""
