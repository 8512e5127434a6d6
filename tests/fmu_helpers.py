"""Test helpers shared by the FMU tests (test_native_fmu.py, test_fmu_safety.py and the tests
that import from them): ``Inst``, an FMI 2.0 co-simulation instance run through fmpy."""
import shutil
from ctypes import byref

from fmpy import extract, fmi2, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.logging import addLoggerProxy

#: the reducer's Real outputs that ``Inst.outputs`` reads (both reducer FMUs have them)
REDUCER_OUTPUTS = ("w_out", "tau_in", "tau_housing", "P_loss", "PL1", "PL2", "PL3", "PL5", "PL6",
                   "eta", "eta0", "P_extra", "P_stored", "PL_support", "PL_seal", "PL_churn",
                   "torque_out", "tau_in_static", "J_load", "J_load_dec", "PL_mesh")


class Inst:
    """An FMU2Slave with name-based access and the log of its messages (fmpy's logger proxy
    formats the message as FMI Library does), started (set up, ``params`` set in
    Initialization Mode, initialised) unless ``start=False``.

    ``unzip``: an extracted FMU to use (else the FMU is extracted, and removed at ``close``);
    ``logging``: the instance's debug logging at instantiation."""

    def __init__(self, path, name="inst", unzip=None, start=True, logging=False, **params):
        self.md = read_model_description(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self._own_dir = unzip is None
        self.dir = unzip or extract(path)
        self.messages = []

        def logger(component, instance, status, category, message):
            self.messages.append((status, message.decode(errors="replace")))
        self.callbacks = fmi2.fmi2CallbackFunctions()
        self.callbacks.logger = fmi2.fmi2CallbackLoggerTYPE(logger)
        self.callbacks.allocateMemory = fmi2.fmi2CallbackAllocateMemoryTYPE(fmi2.calloc)
        self.callbacks.freeMemory = fmi2.fmi2CallbackFreeMemoryTYPE(fmi2.free)
        addLoggerProxy(byref(self.callbacks))
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate(loggingOn=logging, callbacks=self.callbacks)
        self.t = 0.0
        if start:
            self.start(**params)

    def start(self, **params):
        """Set up at t = 0, set ``params`` in Initialization Mode, initialise (also after
        ``fmu.reset()``)."""
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.set(**params)
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def set(self, **values):
        for k, v in values.items():
            t = self.types[k]
            if t == "Real":
                self.fmu.setReal([self.vr[k]], [float(v)])
            elif t == "Integer":
                self.fmu.setInteger([self.vr[k]], [int(v)])
            elif t == "Boolean":
                self.fmu.setBoolean([self.vr[k]], [bool(v)])
            else:
                self.fmu.setString([self.vr[k]], [str(v)])

    def get(self, *names):
        """Real values by name; a Boolean among them is read as a Boolean."""
        if all(self.types[n] == "Real" for n in names):
            return self.fmu.getReal([self.vr[n] for n in names])
        return [self.fmu.getBoolean([self.vr[n]])[0] if self.types[n] == "Boolean"
                else self.fmu.getReal([self.vr[n]])[0] for n in names]

    def outputs(self):
        """The reducer's outputs by name (REDUCER_OUTPUTS and ``locked``)."""
        vals = dict(zip(REDUCER_OUTPUTS, self.get(*REDUCER_OUTPUTS)))
        vals["locked"] = bool(self.fmu.getBoolean([self.vr["locked"]])[0])
        return vals

    def step(self, w_in=None, tau_out=None, dt=1e-3, **inputs):
        """One step of ``dt`` after setting the inputs (``w_in``, ``tau_out`` of a reducer, or
        any by name). A reducer's step returns its ``outputs()``, another FMU's None."""
        if w_in is not None:
            inputs["w_in"] = w_in
        if tau_out is not None:
            inputs["tau_out"] = tau_out
        self.set(**inputs)
        self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=dt)
        self.t += dt
        return self.outputs() if "locked" in self.vr and "w_out" in self.vr else None

    def close(self):
        """Terminate (if the instance's state allows it) and free; remove what was extracted."""
        try:
            self.fmu.terminate()
        except Exception:   # noqa: BLE001 - a test may leave it in another state
            pass
        self.fmu.freeInstance()
        if self._own_dir:
            shutil.rmtree(self.dir, ignore_errors=True)
