"""Each compiled kernel gives what its reference function gives, bit for bit.

The kernels (firmware_sim.nav.frontend_kernels, ins_kernels) against the array-level functions of
firmware_sim.nav.frontend and ins, on random inputs that include ±0, ±inf, NaNs of either sign and
any payload, int32 / uint32 extremes and saturated int16 sensor registers. Floats are compared as
their bits (a NaN's payload and a zero's sign count). Every test runs each kernel as plain Python
(in every job) and compiled (when numba is there).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from firmware_sim.nav import config as cfg
from firmware_sim.nav import frontend as fe
from firmware_sim.nav import frontend_kernels as fk
from firmware_sim.nav import ins, jit
from firmware_sim.nav import ins_arithmetic as arith
from firmware_sim.nav import ins_kernels as ik
from firmware_sim.nav.config import MODULE_INS_NOISE
from firmware_sim.nav.profiles import PROFILES
from firmware_sim.nav.records import WorkRecord
from protocol.ids import NR_IMUS

#: The inputs are meant to overflow and to be invalid: numpy's warnings say nothing here.
pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

FORMS = [
    pytest.param(False, id="python"),
    pytest.param(True, id="compiled", marks=pytest.mark.skipif(
        not jit.COMPILING, reason=f"kernels are not compiled here: {jit.NUMBA_ERROR}")),
]
#: Hypothesis: a kernel's first call compiles it (or loads it from the cache).
kernel_settings = settings(deadline=None, max_examples=150, suppress_health_check=[HealthCheck.too_slow])

F32 = np.float32
I32_MIN, I32_MAX, U32_MAX = -(2 ** 31), 2 ** 31 - 1, 2 ** 32 - 1
#: Bit patterns of float32 specials: ±0, ±inf, quiet NaNs of either sign, NaNs with payloads (one
#: signalling), the smallest subnormal, the largest finite.
SPECIAL_BITS = [0x00000000, 0x80000000, 0x7F800000, 0xFF800000, 0x7FC00000, 0xFFC00000, 0x7FC12345,
                0xFFA00001, 0x00000001, 0x7F7FFFFF, 0xFF7FFFFF]


def form(kernel, compiled: bool):
    """The kernel compiled, or as plain Python (with every kernel it calls)."""
    return kernel if compiled else jit.plain(kernel)


# ------------------------------------------------------------------------------------ inputs
def f32_bits(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float32).view(np.uint32)


@st.composite
def f32_arrays(draw, shape, low=-10.0, high=10.0, specials=3):
    """float32 of a realistic size, up to *specials* elements replaced by a special value."""
    a = draw(hnp.arrays(np.float32, shape, elements=_floats32(low, high)))
    flat = a.reshape(-1).view(np.uint32)
    for _ in range(draw(st.integers(0, specials))):
        flat[draw(st.integers(0, flat.size - 1))] = draw(st.sampled_from(SPECIAL_BITS))
    return a


def _floats32(low, high):
    return st.floats(float(F32(low)), float(F32(high)), width=32)


def f32_scalar(low=-10.0, high=10.0):
    return st.one_of(_floats32(low, high).map(F32),
                     st.sampled_from(SPECIAL_BITS).map(lambda b: np.array(b, np.uint32).view(F32)[()]))


def ints(dtype, shape):
    """Integers of *dtype*, its extremes and their neighbours likely."""
    info = np.iinfo(dtype)
    edge = st.sampled_from([info.min, info.min + 1, -1, 0, 1, info.max - 1, info.max]).filter(
        lambda v: info.min <= v <= info.max)
    return hnp.arrays(dtype, shape, elements=st.one_of(edge, st.integers(info.min, info.max)))


def saturated_registers():
    """int16 registers (chips, 6), often pinned at ±32768 / 32767."""
    pinned = st.sampled_from([-32768, 32767])
    return hnp.arrays(np.int16, (NR_IMUS, 6), elements=st.one_of(pinned, st.integers(-32768, 32767)))


@st.composite
def covariances(draw, specials=True):
    """P's 45-element triangle: symmetric positive, sometimes with its position and yaw terms zeroed
    (as after a step's reset) or a few elements special."""
    a = draw(hnp.arrays(np.float32, (9, 9), elements=st.floats(-1, 1, width=32)))
    scale = draw(st.sampled_from([F32(1e-6), F32(1e-3), F32(1.0)]))
    pm = ((a @ a.T) * scale).astype(np.float32)
    p45 = pm[np.triu_indices(9)].astype(np.float32)
    if draw(st.booleans()):
        p45[ins._RESET_MASK] = F32(0.0)
    bits = p45.view(np.uint32)
    for _ in range(draw(st.sampled_from([0, 0, 0, 1, 2])) if specials else 0):
        bits[draw(st.integers(0, 44))] = draw(st.sampled_from(SPECIAL_BITS))
    return p45


@st.composite
def quaternions(draw, specials=True):
    q = draw(hnp.arrays(np.float32, 4, elements=st.floats(-1, 1, width=32)))
    n = np.sqrt(np.sum(q.astype(np.float64) ** 2))
    q = (q / n).astype(np.float32) if n > 1e-3 else np.array([0, 0, 0, 1], np.float32)
    if specials and draw(st.integers(0, 9)) == 0:
        q.view(np.uint32)[draw(st.integers(0, 3))] = draw(st.sampled_from(SPECIAL_BITS))
    return q


def dts():
    """A loop's DT: the rates' usual values, 0, and specials."""
    usual = st.sampled_from([F32(0.001), F32(0.004), F32(0.0), F32(-0.0), F32(1e-9)])
    return st.one_of(usual, f32_scalar(0, 1))


# ------------------------------------------------------------------------------------ comparing
def _fresh(a, as_record: bool):
    if isinstance(a, np.ndarray):
        return a.copy()
    if isinstance(a, WorkRecord):
        w = type(a)()
        w.record[...] = a.record
        return w.record[0] if as_record else w
    return a


def _written(a) -> np.ndarray:
    """What a call left in argument *a*: a work record as its structured array (compared field by
    field, each float field as :func:`assert_same` compares floats)."""
    if isinstance(a, np.record):
        return np.frombuffer(a.tobytes(), dtype=a.dtype)
    return a.record if isinstance(a, WorkRecord) else a


def assert_same_call(reference, kernel, *args, nan_choice: bool = True,
                     scratch: tuple[int, ...] = ()) -> None:
    """Run both on copies of *args* (a work object is its record for the kernel); the results and
    every array argument afterwards (but the *scratch* ones) must be equal, floats bit for bit
    (see :func:`assert_same`)."""
    ref_args = [_fresh(a, False) for a in args]
    k_args = [_fresh(a, True) for a in args]
    with np.errstate(all="ignore"):
        expected = reference(*ref_args)
        got = kernel(*k_args)
    assert_same(got, expected, "result", nan_choice)
    for i, (r, k) in enumerate(zip(ref_args, k_args, strict=True)):
        if isinstance(r, np.ndarray | WorkRecord) and i not in scratch:
            assert_same(_written(k), _written(r), f"argument {i}", nan_choice)


def assert_same(got, expected, what: str, nan_choice: bool = True) -> None:
    """Equal, floats bit for bit: signed zeros, infinities and NaN payloads.

    *nan_choice*: IEEE 754 leaves the sign and payload of a NaN that arithmetic returns to the
    implementation when two NaNs meet, and the sign of (−x)·c for a NaN x: which one comes out
    depends on the machine code — numpy's scalar and array arithmetic differ, and LLVM folds a
    negation into a constant factor. With such NaNs in play a NaN is accepted for a NaN; every
    other value stays bit for bit. A NaN carried through the arithmetic keeps its sign and
    payload, which :func:`test_a_nan_keeps_its_sign_and_payload_as_in_the_reference` checks
    strictly.
    """
    e = np.asarray(expected)
    g = np.asarray(got)
    if e.dtype.names is not None:  # a work record: each field as itself
        assert g.dtype == e.dtype, what
        for name in e.dtype.names:
            assert_same(g[name], e[name], f"{what}: {name}", nan_choice)
        return
    if e.dtype.kind == "f" or g.dtype.kind == "f":
        assert g.shape == e.shape, what
        same = f32_bits(g) == f32_bits(e)
        if nan_choice:
            same |= np.isnan(np.asarray(g, np.float32)) & np.isnan(np.asarray(e, np.float32))
        assert same.all(), f"{what}: {g!r} != {e!r} ({f32_bits(g)} {f32_bits(e)})"
    else:
        assert g.dtype == e.dtype or e.dtype == object or g.shape == (), what
        assert np.array_equal(g, e), f"{what}: {g!r} != {e!r}"


# --------------------------------------------------------------------------------- front end
@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(raw=saturated_registers(), cal=ints(np.int32, (NR_IMUS, 2, 3, 3)), bias=ints(np.int32, (6,)))
def test_preproc_kernel_matches_the_reference_on_saturated_registers_and_any_calibration(compiled, raw, cal,
                                                                                         bias):
    assert_same_call(fe.preproc, form(fk.preproc, compiled), raw, cal, bias, np.zeros(6, np.int32),
                     np.zeros(6, np.float32))


@st.composite
def detector_states(draw):
    """A front end's detector state: any buffered samples, slot and running sums (int32 / uint32
    extremes included, whether or not the sums agree with the buffer)."""
    w = fe.FrontendWork()
    w.buf32[...] = draw(ints(np.int32, (cfg.N, 6)))
    w.buf16[...] = draw(ints(np.int16, (cfg.N, 6)))
    w.norm[...] = draw(ints(np.uint32, (cfg.N, 2)))
    w.ts[...] = draw(ints(np.uint32, (cfg.N,)))
    w.newest[0] = draw(st.integers(I32_MIN, I32_MAX))
    w.zaru_ab[...] = draw(ints(np.int32, (6,)))
    w.zaru_cd[...] = draw(ints(np.uint32, (4,)))
    w.zupt_a[...] = draw(ints(np.int32, (3,)))
    w.zupt_cd[...] = draw(ints(np.uint32, (4,)))
    return w


def _statdet_call(fn, u_new, ts, w, th_zupt, th_zaru):
    u_int_k = np.zeros(6, np.int32)
    with np.errstate(all="ignore"):
        fn(u_new, ts, w.buf32, w.buf16, w.norm, w.ts, w.newest, w.zaru_ab, w.zaru_cd, w.zupt_a, w.zupt_cd,
           th_zupt, th_zaru, u_int_k, w.stat_out)
    return u_int_k


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(samples=st.lists(saturated_registers(), min_size=1, max_size=40), state=detector_states(),
       ts=st.integers(0, U32_MAX), th=st.tuples(st.integers(0, U32_MAX), st.integers(0, U32_MAX)))
def test_statdet_kernel_matches_the_reference_on_saturated_registers(compiled, samples, state, ts, th):
    """A run of samples (saturated registers through PREPROC) from any detector state: the same
    statistics, decisions, judged sample and ring buffer after every sample."""
    kernel = form(fk.statdet, compiled)
    ref_w, k_w = fe.FrontendWork(), fe.FrontendWork()
    ref_w.record[...] = k_w.record[...] = state.record
    u_new, u_k = np.zeros(6, np.int32), np.zeros(6, np.float32)
    for i, raw in enumerate(samples):
        fe.preproc(raw, ref_w.cal, ref_w.bias, u_new, u_k)
        stamp = (ts + 64000 * i) & U32_MAX
        expected = _statdet_call(fe.statdet, u_new, stamp, ref_w, *th)
        got = _statdet_call(kernel, u_new, stamp, k_w, *th)
        assert_same(got, expected, f"U_INT_K after sample {i}")
        assert k_w.record.tobytes() == ref_w.record.tobytes(), f"detector state after sample {i}"


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(ab=ints(np.int32, (6,)), cd=ints(np.uint32, (4,)), log2m=st.integers(0, 8),
       sr=st.tuples(st.integers(0, 1024), st.integers(0, 12)))
def test_detector_statistics_match_the_reference_at_int32_and_uint32_extremes(compiled, ab, cd, log2m, sr):
    """T1 and T2 from any running sums: Σ of three squared int32 reaches 3·2^62, past int64."""
    assert_same_call(fe.statistic_t1, form(fk.statistic_t1, compiled), ab[:3], cd, log2m, cfg.G_RED, *sr)
    assert_same_call(fe.statistic_t2, form(fk.statistic_t2, compiled), ab, cd, cfg.LOG2_N, cfg.SR_Q,
                     cfg.SR_SHIFT)


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(x=st.one_of(st.integers(0, 2 ** 64 - 1),
                   st.integers(1, 2 ** 32 - 1).flatmap(lambda r: st.sampled_from([r * r - 1, r * r,
                                                                                   r * r + 2 * r]))))
def test_isqrt64_kernel_is_the_floor_root_over_all_of_uint64(compiled, x):
    assert int(form(fk.isqrt64, compiled)(np.uint64(x))) == fe.isqrt64(x) == math.isqrt(x)


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(u_int_k=ints(np.int32, (6,)), zaru=st.booleans(), bias=f32_arrays(3, -0.1, 0.1),
       p=f32_arrays(1, 0, 1e-3))
def test_biasest_kernel_matches_the_reference(compiled, u_int_k, zaru, bias, p):
    assert_same_call(fe.biasest, form(fk.biasest, compiled), u_int_k, zaru, bias, p,
                     np.array([cfg.BIAS_Q], np.float32))


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(u_int_k=ints(np.int32, (6,)), t=st.tuples(st.integers(0, U32_MAX), st.integers(0, U32_MAX)),
       bias=f32_arrays(3, -0.1, 0.1))
def test_convcomp_kernel_matches_the_reference_across_the_counter_wrap(compiled, u_int_k, t, bias):
    t_int_k, t_prev = t
    assert_same_call(fe.convcomp, form(fk.convcomp, compiled), u_int_k, t_int_k, bias,
                     np.array([t_prev], np.uint32), np.zeros(6, np.float32), np.zeros((), np.float32))


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(imu=saturated_registers(), raw=ints(np.int16, (32, 6)), prev=ints(np.int16, (NR_IMUS, 3)),
       have_prev=st.booleans())
def test_the_loops_register_latch_matches_read_inertials(compiled, imu, raw, prev, have_prev):
    from firmware_sim.nav import driver, inertial

    assert_same_call(inertial.latch_registers, form(driver.latch, compiled), imu, raw, prev,
                     np.array([have_prev]))


# ---------------------------------------------------------------------------------------- INS
@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(x=f32_scalar(-100, 100), y=f32_scalar(-100, 100))
def test_trigonometry_matches_the_reference_on_signed_zeros_infinities_and_nan(compiled, x, y):
    for name in ("_sinf", "_cosf", "_tanf"):
        assert_same_call(getattr(arith, name), form(getattr(ik, name), compiled), x)
    assert_same_call(arith._atan2f, form(ik._atan2f, compiled), x, y)


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(a=quaternions(), b=quaternions(), s=f32_arrays((3, 3), -2, 2))
def test_rotation_and_quaternion_helpers_match_the_reference(compiled, a, b, s):
    assert_same_call(arith.quat_to_rot, form(ik.quat_to_rot, compiled), a)
    assert_same_call(arith.quat_mul, form(ik.quat_mul, compiled), a, b)
    assert_same_call(arith.rot_to_yaw, form(ik.rot_to_yaw, compiled), arith.quat_to_rot(a))
    assert_same_call(arith._normalise, form(ik._normalise, compiled), b)
    s = s + s.T
    assert_same_call(arith.inv3_sym_upper, form(ik.inv3_sym_upper, compiled), s[0, 0], s[0, 1], s[0, 2],
                     s[1, 1], s[1, 2], s[2, 2])


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(p45=covariances())
def test_covariance_triangle_unpacks_and_packs_as_the_reference(compiled, p45):
    pm = np.zeros((9, 9), np.float32)
    assert_same_call(arith.unpack_p, form(ik.unpack_p, compiled), p45, pm)
    assert_same_call(arith.pack_p, form(ik.pack_p, compiled), arith.unpack_p(p45, pm),
                     np.zeros(45, np.float32))


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(u_k=f32_arrays(6, -30, 30), dt=dts(), zaru=st.booleans(), pos=f32_arrays(3, -50, 50),
       vel=f32_arrays(3, -5, 5), quat=quaternions())
def test_mechanization_kernel_matches_the_reference_bit_for_bit(compiled, u_k, dt, zaru, pos, vel, quat):
    assert_same_call(ins.mechanization, form(ik.mechanization, compiled), u_k, dt, zaru, pos, vel, quat,
                     np.zeros(3, np.float32))


#: The filter's noise figures of every sensor profile (the module's own and the recordings').
noise_figures = st.sampled_from([p.ins.as_array() for p in PROFILES.values()])


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(f_n=f32_arrays(3, -30, 30), dt=dts(), zaru=st.booleans(), p45=covariances(), noise=noise_figures)
def test_time_update_kernel_matches_the_reference_with_zeroed_terms_and_specials(compiled, f_n, dt, zaru,
                                                                                  p45, noise):
    """P after F P Fᵀ + Q — the kernel sums F's non-zero terms only — equals the full product's,
    signed zeros included (P's position and yaw terms zeroed by a reset make many of them)."""
    assert_same_call(ins.time_update, form(ik.time_update, compiled), f_n, dt, zaru, p45,
                     np.zeros((9, 9), np.float32), noise, scratch=(4,))


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(p45=covariances(), pos=f32_arrays(3, -50, 50), vel=f32_arrays(3, -5, 5), quat=quaternions(), dt=dts(),
       noise=noise_figures)
def test_zupt_update_kernel_matches_the_reference_bit_for_bit(compiled, p45, pos, vel, quat, dt, noise):
    assert_same_call(ins.zupt_update, form(ik.zupt_update, compiled), pos, vel, quat, p45,
                     np.zeros((9, 9), np.float32), dt, noise)


@st.composite
def reset_timers(draw):
    """The step-wise reset's timers near their thresholds (0.75 s, 0.25 s), pending or not."""
    w = ins.InsWork()
    w.t_since_reset[0] = draw(st.one_of(_floats32(0.7, 0.8), f32_scalar(0, 2)))
    w.t_pending[0] = draw(st.one_of(_floats32(0.2, 0.3), f32_scalar(0, 1)))
    w.pending[0] = draw(st.booleans())
    w.t_swing[0] = draw(f32_scalar(0, 2))
    return w


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(zupt=st.booleans(), dt=dts(), w=reset_timers(), pos=f32_arrays(3, -5, 5), quat=quaternions(),
       p45=covariances(), var_vx=st.sampled_from([F32(1e-5), F32(1e-4), F32(2e-4)]))
def test_stepwise_reset_kernel_matches_the_reference_at_the_end_of_a_step(compiled, zupt, dt, w, pos, quat,
                                                                           p45, var_vx):
    """The same step (DX, DP), swing time (SWING_TIME, counted while ZUPT is false), timers and P."""
    p45[ins.P24_INDEX] = var_vx
    assert_same_call(ins.stepwise_reset, form(ik.stepwise_reset, compiled), zupt, dt, w, pos, quat, p45,
                     np.zeros(4, np.float32), np.zeros(10, np.float32), np.full(1, 7, np.float32))


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(count=st.integers(cfg.ALIGNMENT_SAMPLES - 6, cfg.ALIGNMENT_SAMPLES - 1),
       still=st.lists(st.booleans(), max_size=6),
       f=st.lists(f32_arrays(3, -10, 10, specials=1), min_size=6, max_size=6), pos=f32_arrays(3),
       quat=quaternions())
def test_initial_alignment_kernel_matches_the_reference_through_completion(compiled, count, still, f, pos,
                                                                            quat):
    """A few samples before the count completes, stationary or not: the same averaging, attitude,
    position, velocity, P and INIT_DONE."""
    kernel = form(ik.initial_alignment, compiled)
    ref_w = ins.InsWork()
    ref_w.align_count[0] = count
    ref_w.align_sum[...] = np.array([0.5, -0.3, -9.7], np.float32) * np.float32(count)
    ref_w.t_swing[0] = F32(0.4)
    k_w = ins.InsWork()
    k_w.record[...] = ref_w.record
    ref = [pos.copy(), np.ones(3, np.float32), quat.copy(), np.zeros(45, np.float32),
           np.full(2, 0.25, np.float32), np.full(2, -0.5, np.float32)]
    got = [a.copy() for a in ref]
    completed = False
    for i, zupt in enumerate([*still, True, True, True, True, True, True]):
        with np.errstate(all="ignore"):
            done = ins.initial_alignment(f[i % 6], zupt, ref_w, *ref)
            k_done = kernel(f[i % 6], zupt, k_w.record[0], *got)
        assert bool(k_done) == bool(done)
        completed = completed or bool(done)
        names = ("position", "velocity", "quaternion", "P", "THETA_INIT", "THETA_GROUND")
        for name, g, e in zip(names, got, ref, strict=True):
            assert_same(g, e, f"{name} after sample {i}")
        assert k_w.record.tobytes() == ref_w.record.tobytes()
    if completed:
        assert ref_w.t_swing[0] == 0 and not ref[5].any(), "the alignment clears the swing time and the slope"


# ------------------------------------------------------------------------- HEIGHT_COMPENSATION
def slopes(specials=True):
    """THETA_GROUND or THETA_INIT: angles of real ground (±0.3 rad), sometimes special."""
    return f32_arrays(2, -0.3, 0.3, specials=1 if specials else 0)


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(f=f32_arrays(3, -12, 12), f_sum=f32_arrays(3, -6000, 6000))
def test_foot_angles_kernel_matches_the_reference(compiled, f, f_sum):
    assert_same_call(ins.foot_angles, form(ik.foot_angles, compiled), f)
    assert_same_call(ins.foot_angles, form(ik.foot_angles, compiled), f_sum)


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(pos=st.one_of(f32_arrays(3, -0.1, 0.1, specials=0), f32_arrays(3, -2, 2)), vel=f32_arrays(3, -1, 1),
       quat=quaternions(), p45=covariances(), theta_ground=st.one_of(slopes(specials=False), slopes()))
def test_slope_height_update_kernel_matches_the_reference_in_and_out_of_the_gate(compiled, pos, vel, quat,
                                                                                  p45, theta_ground):
    """The slope measurement: applied (small |h|) or gated (a stair's rise, or h no number) alike."""
    assert_same_call(ins.slope_height_update, form(ik.slope_height_update, compiled), pos, vel, quat, p45,
                     np.zeros((9, 9), np.float32), theta_ground, scratch=(4,))


@st.composite
def stances(draw):
    """HEIGHT_COMPENSATION's work: in a stance or not, its timers near the shortest stance counted and
    the shortest swing before a measured stance."""
    w = ins.HeightWork()
    w.in_stance[0] = draw(st.booleans())
    w.f_sum[...] = draw(f32_arrays(3, -500, 500, specials=1))
    w.t_stance[0] = draw(st.one_of(_floats32(0.045, 0.055), f32_scalar(0, 1)))
    w.t_moving[0] = draw(st.one_of(_floats32(0.045, 0.055), f32_scalar(0, 1)))
    w.step_seen[0] = draw(st.booleans())
    w.step_dir[...] = draw(f32_arrays(2, -1, 1))
    w.step_slope[0] = draw(f32_scalar(-0.1, 0.1))
    w.posture_n[0] = draw(st.sampled_from([0.0, 1.0, 31.0, 32.0]))
    return w


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(w=stances(), loops=st.lists(st.tuples(st.booleans(), f32_arrays(3, -12, 12, specials=1)), min_size=1,
                                   max_size=8),
       dt=dts(), pos=f32_arrays(3, -0.2, 0.2), vel=f32_arrays(3, -1, 1), quat=quaternions(),
       p45=covariances(), theta_init=slopes(), theta_ground=slopes())
def test_height_compensation_kernel_matches_the_reference_over_stances(compiled, w, loops, dt, pos, vel, quat,
                                                                       p45, theta_init, theta_ground):
    """Loops in and out of stance: the slope measurement at a stance's first loop after a swing, the
    stance's sums, the slope learnt at its end — the same work, position, velocity, attitude, P and
    THETA_GROUND after every loop."""
    kernel = form(ik.height_compensation, compiled)
    k_w = ins.HeightWork()
    k_w.record[...] = w.record
    ref = [pos.copy(), vel.copy(), quat.copy(), p45.copy(), np.zeros((9, 9), np.float32), theta_init.copy(),
           theta_ground.copy()]
    got = [a.copy() for a in ref]
    names = ("position", "velocity", "quaternion", "P", "scratch", "THETA_INIT", "THETA_GROUND")
    for i, (zupt, f) in enumerate(loops):
        with np.errstate(all="ignore"):
            ins.height_compensation(zupt, f, dt, w, *ref)
            kernel(zupt, f, dt, k_w.record[0], *got)
        for name, g, e in zip(names, got, ref, strict=True):
            if name != "scratch":
                assert_same(g, e, f"{name} after loop {i}")
        assert_same(k_w.record, w.record, f"work after loop {i}")


# ------------------------------------------------------------------------------- one NaN, strictly
#: NaNs of either sign, with and without payload, quiet and signalling.
NAN_BITS = [0x7FC00000, 0xFFC00000, 0x7FC12345, 0xFFA00001, 0x7F800001]


def _one_nan(data, nan_bits, *arrays):
    """Copies of *arrays* with one element of one of them (drawn) replaced by the NaN."""
    out = [a.copy() for a in arrays]
    target = out[data.draw(st.integers(0, len(out) - 1))].reshape(-1).view(np.uint32)
    target[data.draw(st.integers(0, target.size - 1))] = nan_bits
    return out


@pytest.mark.parametrize("compiled", FORMS)
@kernel_settings
@given(data=st.data(), nan=st.sampled_from(NAN_BITS), dt=st.sampled_from([F32(0.001), F32(0.004)]),
       zaru=st.booleans(), quat=quaternions(specials=False), p45=covariances(specials=False))
def test_a_nan_keeps_its_sign_and_payload_as_in_the_reference(compiled, data, nan, dt, zaru, quat, p45):
    """One NaN in a kernel's input — of any sign and payload, quiet or signalling — comes out with
    the bits the reference gives it, wherever it spreads. (Inputs whose NaN would reach (−x)·½ —
    ZUPT_UPDATE's velocity and P, the reset's heading — are left out: see :func:`assert_same`.)"""
    def finite(shape, low=-5, high=5):
        return data.draw(f32_arrays(shape, low, high, specials=0))

    strict = {"nan_choice": False}
    u_k, pos, vel, q = _one_nan(data, nan, finite(6), finite(3), finite(3, -1, 1), quat)
    assert_same_call(ins.mechanization, form(ik.mechanization, compiled), u_k, dt, zaru, pos, vel, q,
                     np.zeros(3, np.float32), **strict)
    (p,) = _one_nan(data, nan, p45)
    noise = MODULE_INS_NOISE.as_array()
    assert_same_call(ins.time_update, form(ik.time_update, compiled), finite(3, -10, 10), dt, zaru, p,
                     np.zeros((9, 9), np.float32), noise, scratch=(4,), **strict)
    (pos,) = _one_nan(data, nan, finite(3))
    assert_same_call(ins.zupt_update, form(ik.zupt_update, compiled), pos, finite(3, -1, 1), quat, p45,
                     np.zeros((9, 9), np.float32), dt, noise, **strict)
    w = ins.InsWork()
    w.t_since_reset[0], w.pending[0] = F32(0.8), data.draw(st.booleans())
    pos, p = _one_nan(data, nan, finite(3), p45)
    p[ins.P24_INDEX] = F32(1e-5)
    assert_same_call(ins.stepwise_reset, form(ik.stepwise_reset, compiled), data.draw(st.booleans()), dt, w,
                     pos, quat, p, np.zeros(4, np.float32), np.zeros(10, np.float32), np.zeros(1, np.float32),
                     **strict)
    gyro_bias, bias_p = _one_nan(data, nan, finite(3, -0.1, 0.1), np.array([1e-4], np.float32))
    u_int_k = data.draw(ints(np.int32, (6,)))
    assert_same_call(fe.biasest, form(fk.biasest, compiled), u_int_k, True, gyro_bias, bias_p,
                     np.array([cfg.BIAS_Q], np.float32), **strict)
    assert_same_call(fe.convcomp, form(fk.convcomp, compiled), u_int_k, 7, gyro_bias,
                     np.array([3], np.uint32), np.zeros(6, np.float32), np.zeros((), np.float32), **strict)
    x = np.array(nan, np.uint32).view(np.float32)[()]
    for name in ("_sinf", "_cosf", "_tanf"):
        assert_same_call(getattr(arith, name), form(getattr(ik, name), compiled), x, **strict)
    assert_same_call(arith._atan2f, form(ik._atan2f, compiled), x, dt, **strict)
    assert_same_call(arith._atan2f, form(ik._atan2f, compiled), dt, x, **strict)


@pytest.mark.skipif(not jit.COMPILING, reason=f"kernels are not compiled here: {jit.NUMBA_ERROR}")
def test_every_cached_kernel_is_renewed_when_any_kernel_source_changes():
    """A kernel compiled into another (the driver holds them all) lives in that one's cache entry:
    each entry is stamped with all the sources, not only its own file's."""
    from firmware_sim.nav import driver

    sources = {p.name for p in jit.SOURCES}
    assert {"driver.py", "frontend_kernels.py", "ins_kernels.py", "frontend.py", "ins.py", "config.py",
            "ids.py", "states.py", "memory.py"} <= sources
    for k in (driver.run_loops, fk.statdet, ik.time_update, ik.stepwise_reset):
        assert k._cache._impl.locator.get_source_stamp() == jit._sources_stamp()
