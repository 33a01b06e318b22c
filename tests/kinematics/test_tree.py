import numpy as np
import pinocchio as pin


def test_frames_equal_pinocchio_with_corrections(justin):
    rng = np.random.default_rng(3)
    tree = justin.tree
    q = rng.uniform(-2, 2, size=(4, tree.model.nq))
    fixes = {j: pin.exp6(rng.normal(0, 0.02, 6)) for j in (2, 8, 15)}
    frames = tree.frames(q, fixes)
    model = tree.model.copy()
    for j, fix in fixes.items():
        model.jointPlacements[j] = model.jointPlacements[j] * fix
    data = model.createData()
    for i in range(len(q)):
        pin.forwardKinematics(model, data, q[i])
        for j in range(1, tree.nj):
            assert np.allclose(frames.origin[i, j], data.oMi[j].translation, atol=1e-12)
            assert np.allclose(frames.rotation[i, j], data.oMi[j].rotation, atol=1e-12)


def test_coupled_joint_follows_its_law(justin):
    q = justin.model_configuration(np.arange(19.0)[None, :] * 0.01)
    torso4 = justin.tree.idx_q[justin.tree.names.index("torso4_joint")]
    assert np.isclose(q[0, torso4], -(0.01 + 0.02))
