"""Puts the native parts into the package as it is built (pyproject.toml has the metadata):
libkata.so from $KATA_LIBRARY or <repo>/build/lib, and the FlatBuffers readers flatc generated
(kata/fb/*.py) from $KATA_PYTHON_FB or <repo>/build/python/kata/fb, and the scoring model
(kata/models/default.kata) from $KATA_MODEL or <repo>/models/default.kata, and the CMU clips the
docs' examples use (kata/data/cmu: 02_01, 07_01, 05_18 and the licence) from $KATA_DATA or
<repo>/data/cmu, so kata.find_data finds them in the package. The version is kata.h's.
Nothing is written into the source folder: build/ and kata.egg-info go to a scratch folder."""
import atexit
import os
import re
import shutil
import sys
import tempfile

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

try:  # setuptools >= 70.1 carries bdist_wheel; older ones take it from the wheel package
    from setuptools.command.bdist_wheel import bdist_wheel  # type: ignore[import-not-found]
except ImportError:
    try:
        from wheel.bdist_wheel import bdist_wheel
    except ImportError:
        raise SystemExit("kata: %s cannot build a wheel: it has neither the 'wheel' package nor a setuptools >= 70.1. "
                         "Use Debian's python (apt-get install python3-wheel python3-numpy; /usr/bin/python3 -m venv "
                         "--system-site-packages v && v/bin/pip install --no-build-isolation ./bindings/python), or "
                         "install wheel and numpy for this python first" % sys.executable)

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))


def _version():
    header = os.environ.get("KATA_HEADER", os.path.join(REPO, "sdk", "include", "kata", "core.h"))
    with open(header, encoding="utf-8") as f:
        text = f.read()
    parts = [re.search(r"#define KATA_VERSION_%s (\d+)" % k, text) for k in ("MAJOR", "MINOR", "PATCH")]
    if not all(parts):
        raise SystemExit("%s: no KATA_VERSION_MAJOR/MINOR/PATCH" % header)
    return ".".join(m.group(1) for m in parts if m)


def _native_library():
    path = os.environ.get("KATA_LIBRARY") or os.path.join(REPO, "build", "lib", "libkata.so")
    if not os.path.isfile(path):
        raise SystemExit("kata: libkata.so not found at %s: build it first (cmake --build build --target kata) "
                         "or set KATA_LIBRARY to its path" % path)
    return os.path.realpath(path)


def _fb_dir():
    path = os.environ.get("KATA_PYTHON_FB") or os.path.join(REPO, "build", "python", "kata", "fb")
    if not os.path.isfile(os.path.join(path, "Result.py")):
        raise SystemExit("kata: the generated FlatBuffers readers are not in %s: build them first "
                         "(cmake --build build --target kata_schemas_python) or set KATA_PYTHON_FB" % path)
    return path


# The clips the README's and the package docstring's examples load with kata.find_data, and their
# licence (data/cmu/README.md): 2 MB of the 4 MB that `cmake --install` puts in share/kata.
WHEEL_CLIPS = ("02_01.bvh", "07_01.bvh", "05_18.bvh", "README.md")


class BuildWithNative(build_py):
    """build_py, then libkata.so and kata/fb copied into the build tree (never into the sources)."""

    def run(self):
        super().run()
        package = os.path.join(self.build_lib, "kata")
        shutil.copyfile(_native_library(), os.path.join(package, "libkata.so"))
        fb_out = os.path.join(package, "fb")
        shutil.rmtree(fb_out, ignore_errors=True)
        shutil.copytree(_fb_dir(), fb_out, ignore=shutil.ignore_patterns("__pycache__"))
        open(os.path.join(fb_out, "__init__.py"), "a").close()
        model = os.environ.get("KATA_MODEL") or os.path.join(REPO, "models", "default.kata")
        if not os.path.isfile(model):
            raise SystemExit("kata: the default model %s is missing (set KATA_MODEL)" % model)
        os.makedirs(os.path.join(package, "models"), exist_ok=True)
        shutil.copyfile(model, os.path.join(package, "models", "default.kata"))
        clips = os.environ.get("KATA_DATA") or os.path.join(REPO, "data", "cmu")
        os.makedirs(os.path.join(package, "data", "cmu"), exist_ok=True)
        for name in WHEEL_CLIPS:
            if not os.path.isfile(os.path.join(clips, name)):
                raise SystemExit("kata: %s is missing from %s (set KATA_DATA to the folder of kata's data/cmu)" % (name, clips))
            shutil.copyfile(os.path.join(clips, name), os.path.join(package, "data", "cmu", name))


class PlatformWheel(bdist_wheel):
    """Pure Python code, but a native library inside: py3-none-<platform>."""

    def finalize_options(self):
        super().finalize_options()
        self.root_is_pure = False

    def get_tag(self):
        _, _, platform = super().get_tag()
        return "py3", "none", platform


class NativeDistribution(Distribution):
    def has_ext_modules(self):
        return True


# pip builds in the source folder: its build/ and kata.egg-info go to a scratch folder instead.
_SCRATCH = tempfile.mkdtemp(prefix="kata-pip-build-")
atexit.register(shutil.rmtree, _SCRATCH, True)

setup(version=_version(), distclass=NativeDistribution,
      cmdclass={"build_py": BuildWithNative, "bdist_wheel": PlatformWheel},
      options={"build": {"build_base": os.path.join(_SCRATCH, "build")}, "egg_info": {"egg_base": _SCRATCH}})
