"""Work around a bpy-as-a-Python-module bug that breaks Mantaflow (smoke/liquid) baking.

Symptom (bpy 4.2 .. 5.0.1 from PyPI, Linux):
    AttributeError: 'LevelsetGrid' object has no attribute 'setConst'
    ...
    terminate called after throwing an instance of 'Manta::Error'
      what():  can't clean grid cache, some grids are still in use

Cause: in WITH_PYTHON_MODULE builds Blender calls Pb::PyInit_manta_main() (which builds the
Python types of the `manta` module) while `import bpy` runs, *before* Mantaflow's
Pb::setup() -> WrapperRegistry::construct() has copied the base-class methods into the
derived classes (registerBaseclasses/addParentMethods). So e.g. LevelsetGrid lacks
Grid<Real>.setConst. In the normal Blender executable the module is only created lazily
after Pb::setup(), so it works there.

Fix: load bpy's __init__.so with ctypes *before* `import bpy`, call the (hidden, but present
in .symtab) C++ function
    Pb::setup(bool, std::string const&, std::vector<std::string> const&, PyObject*)
with python_lifecycle=false, then `import bpy` normally: the same shared object is reused,
and the manta module is created from a fully constructed registry.

Usage: `import manta_fix; manta_fix.apply()` BEFORE `import bpy`. Needs `nm` (binutils).
Only the add-on's test needs it, to bake a Mantaflow domain with bpy from PyPI; Blender
itself bakes without it.
"""
import ctypes
import importlib.util
import os
import subprocess
import sys

_SETUP_MANGLED = ("_ZN2Pb5setupEbRKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEE"
                  "RKSt6vectorIS5_SaIS5_EEP7_object")
_ANCHOR = "PyInit_manta_main"  # exported (dynamic) symbol used to find the load base


def _sym_addrs(so_path):
    out = subprocess.run(["nm", so_path], check=True, capture_output=True, text=True).stdout
    addrs = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[2] in (_SETUP_MANGLED, _ANCHOR):
            addrs[parts[2]] = int(parts[0], 16)
    return addrs


def apply():
    if "bpy" in sys.modules:
        raise RuntimeError("manta_fix.apply() must run before `import bpy`")
    spec = importlib.util.find_spec("bpy")
    so_path = spec.origin  # .../site-packages/bpy/__init__.so
    addrs = _sym_addrs(so_path)
    if _SETUP_MANGLED not in addrs or _ANCHOR not in addrs:
        raise RuntimeError(f"symbols not found in {so_path}: {sorted(addrs)}")
    lib = ctypes.PyDLL(so_path, mode=os.RTLD_NOW)  # PyDLL: keep the GIL during the call
    anchor = ctypes.cast(getattr(lib, _ANCHOR), ctypes.c_void_p).value
    setup_addr = anchor - addrs[_ANCHOR] + addrs[_SETUP_MANGLED]

    # libstdc++ (C++11 ABI) empty std::string: {char* p; size_t len; char buf[16]} with p=&buf
    s = (ctypes.c_char * 32)()
    s_addr = ctypes.addressof(s)
    ctypes.c_void_p.from_address(s_addr).value = s_addr + 16
    ctypes.c_size_t.from_address(s_addr + 8).value = 0
    # empty std::vector<std::string>: {begin, end, cap} = nullptrs
    v = (ctypes.c_char * 24)()
    ns = {"__builtins__": __builtins__}

    proto = ctypes.PYFUNCTYPE(None, ctypes.c_bool, ctypes.c_void_p, ctypes.c_void_p, ctypes.py_object)
    setup = proto(setup_addr)
    # Pb::setup -> runPreInit also runs Mantaflow's registered snippet code, prefixed with
    # "from manta import *". `manta` does not exist yet at this point, so that snippet fails with
    # an ImportError that is printed via PyErr_Print; it is harmless (Blender re-runs it on every
    # later Pb::setup call, once `manta` exists). Capture it so the log stays clean.
    import io
    old_err, buf = sys.stderr, io.StringIO()
    sys.stderr = buf
    try:
        setup(False, s_addr, ctypes.addressof(v), ns)
    finally:
        sys.stderr = old_err
    _keep.extend([lib, s, v, ns])
    return True


_keep = []
