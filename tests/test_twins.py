"""The twins' counter-based generator: one source, the same directions in Python, numba's CPU and CUDA kernels."""

from __future__ import annotations

import numpy as np
import pytest

from robodyn.integrators import twins
from robodyn.integrators.stability import lyapunov

from .test_cuda_batch import _simulated

# The same float64 operations in the same order (the generator is integer arithmetic, then one log, sqrt
# and cos from the C library): the directions agree to the bit.
SAME_BITS = 0.0
D0 = 1e-8
STREAMS = (0, 1, 5, 2**32 - 1 + 999_999, 2**63 + 7)


def test_splitmix64_is_the_reference_generator():
    """SplitMix64 from state 0: the first outputs of Vigna's reference C code (state += golden ratio, then mix)."""
    state, got = np.uint64(0), []
    with np.errstate(over="ignore"):
        for _ in range(3):
            got.append(int(twins.splitmix64(state)))
            state = state + np.uint64(twins.GOLDEN)
    assert got == [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F]


def test_directions_are_normal_and_scaled():
    z = np.array([twins.direction(s, 4, 1.0) for s in range(4000)])
    np.testing.assert_allclose(np.linalg.norm(z, axis=1), 1.0, rtol=1e-15)
    with np.errstate(over="ignore"):
        x = np.array([twins.normal(np.uint64(s), np.uint64(0)) for s in range(20000)])
    # 20,000 standard normals: mean within 4 standard errors (0.028), std within 2 %.
    assert abs(x.mean()) < 0.03 and abs(x.std() - 1.0) < 0.02
    assert len({tuple(twins.direction(s, 2, 1.0)) for s in range(100)}) == 100


def test_numba_cpu_offsets_equal_python_directions():
    """The kernels' offset function, compiled by numba.njit, gives twins.direction's numbers (nv 2 and 1)."""
    import numba

    from robodyn.engine.cuda import batch as cuda_batch

    offset = cuda_batch._twin_offset(numba.njit)
    for stream in STREAMS:
        got2 = np.array(offset(2, np.uint64(stream), D0))
        np.testing.assert_allclose(got2, twins.direction(stream, 4, D0), rtol=0, atol=SAME_BITS)
        got1 = np.array(offset(1, np.uint64(stream), D0))
        want1 = twins.direction(stream, 2, D0)
        np.testing.assert_allclose(got1, [want1[0], 0.0, want1[1], 0.0], rtol=0, atol=SAME_BITS)


def test_cuda_simulator_offsets_equal_python_directions():
    """In numba's CUDA simulator, a kernel drawing every thread's offset gives twins.direction's numbers."""
    out = _simulated(
        f"""
        import json
        import numpy as np
        from robodyn.engine.cuda import batch as cuda_batch
        from robodyn.integrators import twins

        cuda = cuda_batch.cuda_module()
        offset = cuda_batch._twin_offset(cuda.jit(device=True))

        @cuda.jit
        def kernel(nv, S, out):
            r = cuda.grid(1)
            if r < S.shape[0]:
                out[r, 0], out[r, 1], out[r, 2], out[r, 3] = offset(nv, S[r], {D0})

        S = np.array({list(STREAMS)}, dtype=np.uint64)
        worst = 0.0
        for nv in (2, 1):
            out = np.zeros((S.size, 4))
            kernel[1, 32](nv, S, out)
            for k, s in enumerate(S):
                want = twins.direction(int(s), 2 * nv, {D0})
                got = out[k] if nv == 2 else out[k, [0, 2]]
                worst = max(worst, float(np.max(np.abs(got - want))))
        print(json.dumps({{"worst": worst}}))
        """
    )
    assert out["worst"] <= SAME_BITS, out


def test_lyapunov_twin_starts_at_the_streams_direction():
    """stability.lyapunov's twin starts at q0 + twins.direction(seed): its first step sees exactly that offset."""
    seen = []

    def step_run(q, v, T):
        seen.append(np.concatenate([q, v]))
        return q, v

    lyapunov(step_run, [0.1, 0.2], [0.0, 0.0], duration=1.0, interval=1.0, d0=D0, seed=7)
    np.testing.assert_array_equal(
        seen[1] - seen[0], np.array([0.1, 0.2, 0.0, 0.0]) + twins.direction(7, 4, D0) - [0.1, 0.2, 0.0, 0.0]
    )


@pytest.mark.parametrize("seed", [-1, 2**64, 1.5])
def test_lyapunov_seed_out_of_range_is_an_input_error(seed):
    from robodyn.errors import InputError

    with pytest.raises(InputError, match="seed must be a whole number"):
        lyapunov(lambda q, v, T: (q, v), [0.0], [0.0], duration=1.0, interval=1.0, seed=seed)
