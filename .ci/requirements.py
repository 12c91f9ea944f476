"""The Python packages rotorcable installs into a venv, one list for .ci/setup and .ci/tests."""

PACKAGES = ["numpy>=2.0", "meson-python>=0.15", "meson>=1.2", "ninja", "pytest", "matplotlib", "tqdm",
            "dask[distributed]", "dask-jobqueue", "f90nml>=1.4", "h5py", "rainflow", "meshio", "h5netcdf", "xarray", "scipy>=1.11"]

if __name__ == "__main__":
    print(" ".join(PACKAGES))      # callers expand it with globbing off (set -f): "[...]"
