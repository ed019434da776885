"""Where the steps run: the CPU (the compiled loops of ``sim.loops``) or an NVIDIA GPU.

``sim.devices.cuda_lattice`` holds the GPU kernels (written for NVIDIA's ``numba-cuda``, the
optional extra ``gpu``) and ``sim.devices.cuda_stepper`` the stepper that runs them;
``Simulation(..., device="cuda")`` picks it.  numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``)
runs the same kernels on any CPU, slowly, which is how they are tested without a GPU.
"""

DEVICES = ("cpu", "cuda")
"""The devices a ``Simulation`` may run on."""


def check_device(device: object) -> str:
    """``device`` if it is one of ``DEVICES``, else raise ``sim.model.lattice.ModelError``."""
    if device not in DEVICES:
        from sim.model.lattice import ModelError

        raise ModelError(f"device must be one of {', '.join(DEVICES)}, got {device!r}")
    return str(device)
