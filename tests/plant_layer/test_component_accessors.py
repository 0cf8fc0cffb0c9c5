"""The generic pieces of :mod:`plant.component` on a struct of its own (cffi, no compiled library): ``struct_field``'s
array fields and setter checks, the parts a composite points into its struct, the ``name=value`` repr, the ops
table attribute and the configuration from the C defaults and init."""

from __future__ import annotations

import functools
import pickle

import cffi
import numpy as np
import pytest

from plant.component import Component, ops_table, struct_field, struct_fields
from plant.errors import ParameterError, check_finite_scalar

FFI = cffi.FFI()
FFI.cdef("""
typedef struct t_part { double x; long n; } t_part;
typedef struct t_part_config { double x; long n; } t_part_config;
typedef struct t_inner { t_part part; double y; } t_inner;
typedef struct t_whole { long p; double phi[6]; double I; t_part a; t_inner inner; } t_whole;
""")


class _Lib:
    """Stands in for a cffi library: one global ops table, and ``t_part``'s defaults, init and error message."""

    t_ops = FFI.new("t_part *", {"x": 4.5, "n": 7})[0]

    @staticmethod
    def t_part_default_config():
        return {"x": 1.0, "n": 3}

    @staticmethod
    def t_part_init(c, cfg):  # refuses x <= 0 (code 5), else copies the settings and doubles n
        if not cfg.x > 0:
            return 5
        c.x, c.n = cfg.x, 2 * cfg.n
        return 0

    @staticmethod
    def aff_error_message(code):
        return FFI.new("char[]", f"x must be > 0 (code {code})".encode())


class Part(Component):
    _ffi = FFI
    _ctype = "t_part"
    _repr_fields = ("x", "n")
    x = struct_field("x", float, "A value.", settable=True)
    n = struct_field("n", int, "A count.")

    def __init__(self, x: float):
        self._new_struct()
        self.x = x


class Whole(Component):
    _ffi = FFI
    _ctype = "t_whole"
    _parts = {"a": "a", "b": "inner.part", "c": "a"}
    _repr_fields = ("I", "a.x", "b.n")
    C_OPS = "t_ops"
    phi = struct_field("phi", doc="The first p entries.", size="p")
    phi_view = struct_field("phi", doc="The first p entries, in place.", size="p", view=True)
    I = struct_field("I", float, "A state.", settable=True,  # noqa: E741 - the C field's name
                     check=functools.partial(check_finite_scalar, "I"))
    ops = ops_table(_Lib)

    def __init__(self):
        self._new_struct()
        self._attach(a=Part(1.25), b=Part(-3.0), c=None)


def test_an_array_field_reads_a_copy_of_its_first_p_entries_and_refuses_a_write():
    w = Whole()
    for i in range(6):
        w.cdata.phi[i] = 0.5 * i - 1.0
    w.cdata.p = 4
    phi = w.phi
    assert isinstance(phi, np.ndarray) and phi.dtype == np.float64
    np.testing.assert_array_equal(phi, [-1.0, -0.5, 0.0, 0.5])
    phi[0] = 99.0  # a copy: the struct keeps its value
    assert w.cdata.phi[0] == -1.0
    w.cdata.p = 0
    assert w.phi.shape == (0,)
    with pytest.raises(AttributeError):
        w.phi = [1.0]


def test_a_checked_setter_stores_the_checked_value_and_refuses_a_bad_one_unchanged():
    w = Whole()
    w.I = 2
    assert w.I == 2.0 and type(w.I) is float and w.cdata.I == 2.0
    with pytest.raises(ParameterError, match="I must be finite"):
        w.I = float("inf")
    with pytest.raises(TypeError, match="I must be a real number"):
        w.I = "1"
    assert w.cdata.I == 2.0


def test_parts_point_into_the_struct_a_nested_one_by_its_path_and_none_is_skipped():
    w = Whole()
    assert w.a.x == 1.25 and w.cdata.a.x == 1.25  # the part's value was copied into the composite's field
    assert w.b.x == -3.0 and w.cdata.inner.part.x == -3.0
    w.cdata.inner.part.n = 5
    w.a.x = 0.75
    assert w.b.n == 5 and w.cdata.a.x == 0.75  # one struct, two views
    w2 = pickle.loads(pickle.dumps(w))  # a copy re-points its parts into its own struct
    w2.b.x = 8.0
    assert w2.cdata.inner.part.x == 8.0 and w.cdata.inner.part.x == -3.0 and w2.a.x == 0.75


def test_repr_shows_the_named_fields_a_path_by_its_last_name_and_without_names_the_default():
    w = Whole()
    w.I = 0.5
    assert repr(w) == "Whole(I=0.5, x=1.25, n=0)"
    assert repr(Part(2.0)) == "Part(x=2.0, n=0)"
    assert repr(Component()).startswith("<plant.component.Component object at ")


def test_the_ops_attribute_points_at_the_table_c_ops_names():
    w = Whole()
    assert FFI.typeof(w.ops) is FFI.typeof("t_part *")
    assert (w.ops.x, w.ops.n) == (4.5, 7)


def test_an_array_view_shares_the_struct_s_memory_and_its_length_follows_p():
    w = Whole()
    w.cdata.p = 3
    v = w.phi_view
    assert v.dtype == np.float64 and v.shape == (3,) and not v.flags.owndata
    v[1] = 6.5  # a write through the view is the struct's
    assert w.cdata.phi[1] == 6.5 and w.phi[1] == 6.5
    w.cdata.phi[2] = -2.0
    assert v[2] == -2.0
    w.cdata.p = 6
    np.testing.assert_array_equal(w.phi_view, [0.0, 6.5, -2.0, 0.0, 0.0, 0.0])
    with pytest.raises(AttributeError):
        w.phi_view = np.zeros(6)


class Configured(Component):
    _ffi = FFI
    _ctype = "t_part"
    x = struct_field("x", float, "A value.")
    n = struct_field("n", int, "A count.")

    def __init__(self, **fields):
        self._configure_from(_Lib, fields, counts=("n",))


def test_configure_from_takes_the_c_defaults_the_fields_given_and_the_c_init_s_verdict():
    c = Configured()
    assert (c.x, c.n) == (1.0, 6) and (c.config.x, c.config.n) == (1.0, 3)
    c = Configured(x=2.5, n=4)
    assert (c.x, c.n) == (2.5, 8)
    with pytest.raises(ParameterError, match=r"^Configured: x must be > 0 \(code 5\)$"):
        Configured(x=-1.0)
    with pytest.raises(TypeError, match="Configured: n must be an integer"):
        Configured(n=True)


_FIELDS_H = """
typedef struct t_sub {
    double level;             /* a level (N*m), >= 0 */
} t_sub;

typedef struct t_fields {
    double Tc;                /* controller period (s), > 0 */
    long m;                   /* periods per sample,
                               * >= 1 */
    int at_ref;               /* 1: at the reference; 0: at the measurement */
    int64_t n_rejected;       /* refused samples */
    t_sub sub;                /* the part */
    double bare;
    double arr[2];            /* two values */
} t_fields;
"""
FFI.cdef("""
typedef struct t_sub { double level; } t_sub;
typedef struct t_fields { double Tc; long m; int at_ref; int64_t n_rejected; t_sub sub; double bare; double arr[2]; }
    t_fields;
""")


def _fields_class(tmp_path, *fields, **options):
    header = tmp_path / "t_fields.h"
    header.write_text(_FIELDS_H)

    class Fields(Component):
        _ffi = FFI
        _ctype = "t_fields"

        def __init__(self):
            self._new_struct()

    return struct_fields(*fields, header=header, **options)(Fields)


def test_struct_fields_reads_each_field_as_its_c_kind_with_the_header_comment_as_its_doc(tmp_path):
    cls = _fields_class(tmp_path, "Tc", "m", "at_ref", "n_rejected", "sub.level", settable=("m",))
    f = cls()
    f.cdata.Tc, f.cdata.m, f.cdata.at_ref, f.cdata.n_rejected, f.cdata.sub.level = 2e-3, 10, 1, 2**40, 0.25
    got = (f.Tc, f.m, f.at_ref, f.n_rejected, f.level)
    assert got == (2e-3, 10, True, 2**40, 0.25)
    assert [type(v) for v in got] == [float, int, bool, int, float]
    assert cls.Tc.__doc__ == "Controller period (s), > 0 (C ``Tc``)."
    assert cls.m.__doc__ == "Periods per sample, >= 1 (C ``m``)."  # a continuation line's '*' dropped
    assert cls.at_ref.__doc__ == "True: at the reference; False: at the measurement (C ``at_ref``)."
    assert cls.level.__doc__ == "A level (N*m), >= 0 (C ``sub.level``)."  # the nested struct's own declaration
    f.m = 3
    assert f.cdata.m == 3
    with pytest.raises(AttributeError):
        f.Tc = 1.0


@pytest.mark.parametrize("fields, options, what", [
    (("nope",), {}, "'nope'"),            # no such field
    (("sub",), {}, "'sub'"),              # a struct, not a primitive field
    (("arr",), {}, "'arr'"),              # an array
    (("bare",), {}, "'bare' has no comment"),
    (("Tc",), {"settable": ("m",)}, "settable names fields not given: \\['m'\\]"),
    (("Tc", "Tc"), {}, "'Tc' is already defined"),
])
def test_struct_fields_refuses_a_field_it_cannot_declare_naming_it(tmp_path, fields, options, what):
    with pytest.raises(ParameterError, match=what):
        _fields_class(tmp_path, *fields, **options)


def test_struct_fields_without_a_header_that_declares_the_struct_names_the_field(tmp_path):
    cls = _fields_class(tmp_path, "Tc")
    (tmp_path / "other.h").write_text("/* no declaration of t_fields */\n")
    bare = struct_fields("m", header=tmp_path / "other.h")(type("Bare", (cls,), {}))
    assert bare.m.__doc__ == "The C field m of t_fields (C ``m``)."
