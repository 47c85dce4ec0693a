"""Builds the optional native content filter (paramdds/dds/_nodefilter.c).

Everything else is configured in pyproject.toml. The extension is optional: where
no C compiler is present the install still succeeds and paramdds filters in its
request handlers instead (it says so once in the log and in ``paramdds nodes``).
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "paramdds.dds._nodefilter",
            sources=["paramdds/dds/_nodefilter.c"],
            extra_compile_args=["-O2", "-std=c11", "-Wall", "-Wextra"],
            optional=True,
        )
    ]
)
