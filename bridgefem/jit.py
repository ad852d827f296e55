"""In-process memo of the compiled forms and elements (DOLFINx 0.5).

:func:`dolfinx.fem.form` and :class:`dolfinx.fem.FunctionSpace` look every form and element up in the on-disk
JIT cache on each call: a form signature, FFCx parameter merging (logged with ``pprint``), a listing of the cache
directory and a module import, about 0.5 ms each. An analysis builds the same handful of forms and spaces every
time, so the compiled objects are kept here, keyed by what the JIT module name is computed from (the UFL
signature of a form, the element's representation); the DOLFINx objects are then built around them exactly as
DOLFINx does. Every rank builds the same forms in the same order, so the memo is hit or missed on all ranks alike
(the JIT's collective calls stay matched).
"""
from __future__ import annotations

import ufl
from dolfinx import cpp as _cpp
from dolfinx import fem, jit
from dolfinx.fem.forms import FormMetaClass

_FORM_PARAMS = {"scalar_type": "double"}  # what dolfinx.fem.form passes for PETSc's float64 scalars
_FormClass = type("Form", (FormMetaClass, _cpp.fem.Form_float64), {})
_forms: dict[str, tuple] = {}
_elements: dict[str, tuple] = {}


def form(ufl_form: ufl.Form) -> FormMetaClass:
    """:func:`dolfinx.fem.form` of one UFL form (float64), the compiled form taken from the memo when present."""
    domain, = ufl_form.subdomain_data().keys()
    subdomains, = ufl_form.subdomain_data().values()
    mesh = domain.ufl_cargo()
    key = ufl_form.signature()
    if key not in _forms:
        _forms[key] = jit.ffcx_jit(mesh.comm, ufl_form, form_compiler_params=dict(_FORM_PARAMS))
    ufcx_form, module, code = _forms[key]
    V = [arg.ufl_function_space()._cpp_object for arg in ufl_form.arguments()]
    original = ufl_form.coefficients()
    coeffs = [original[ufcx_form.original_coefficient_position[i]]._cpp_object
              for i in range(ufcx_form.num_coefficients)]
    constants = [c._cpp_object for c in ufl_form.constants()]
    sd = {_cpp.fem.IntegralType.cell: subdomains.get("cell"),
          _cpp.fem.IntegralType.exterior_facet: subdomains.get("exterior_facet"),
          _cpp.fem.IntegralType.interior_facet: subdomains.get("interior_facet"),
          _cpp.fem.IntegralType.vertex: subdomains.get("vertex")}
    return _FormClass(ufcx_form, V, coeffs, constants, sd, mesh, module.ffi, code)


def function_space(mesh, element: ufl.FiniteElementBase) -> fem.FunctionSpace:
    """:class:`dolfinx.fem.FunctionSpace` of a UFL element, the compiled element taken from the memo."""
    key = repr(element)
    if key not in _elements:
        _elements[key] = jit.ffcx_jit(mesh.comm, element, form_compiler_params=dict(_FORM_PARAMS))
    (ufcx_element, ufcx_dofmap), module, _ = _elements[key]
    ffi = module.ffi
    cpp_element = _cpp.fem.FiniteElement(ffi.cast("uintptr_t", ffi.addressof(ufcx_element)))
    cpp_dofmap = _cpp.fem.create_dofmap(mesh.comm, ffi.cast("uintptr_t", ffi.addressof(ufcx_dofmap)),
                                        mesh.topology, cpp_element)
    return fem.FunctionSpace(mesh, element, _cpp.fem.FunctionSpace(mesh._mesh, cpp_element, cpp_dofmap))


def vector_space(mesh, family: str, degree: int) -> fem.FunctionSpace:
    """:func:`dolfinx.fem.VectorFunctionSpace` through the memo."""
    return function_space(mesh, ufl.VectorElement(family, mesh.ufl_cell(), degree))


def scalar_space(mesh, family: str, degree: int) -> fem.FunctionSpace:
    """``dolfinx.fem.FunctionSpace(mesh, (family, degree))`` through the memo."""
    return function_space(mesh, ufl.FiniteElement(family, mesh.ufl_cell(), degree))
