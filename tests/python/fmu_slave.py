"""An fmpy FMU2Slave of a packaged FMU whose logger records the FMU's messages instead of
printing them, shared by the tests and by the silent misuse script that runs in a subprocess."""

import shutil
from ctypes import byref

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

FMI2_ERROR = 3


class RecordingLogger:
    """fmi2CallbackFunctions whose logger appends (status, category, message) to a list.

    fmpy's native proxy formats the variadic message before it reaches Python; the ctypes
    objects are kept on the instance so they outlive every FMU instance that uses them."""

    def __init__(self):
        self.messages = []
        self._python_logger = fmi2CallbackLoggerTYPE(self._log)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._python_logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(byref(self.callbacks))

    def _log(self, environment, instance_name, status, category, message):
        self.messages.append((status, category.decode("utf-8", "replace"), message.decode("utf-8", "replace")))

    def errors(self):
        return [m for m in self.messages if m[0] == FMI2_ERROR]


class Packaged:
    """A packaged FMU unpacked once: its model description and value references by name."""

    def __init__(self, path):
        self.path = path
        self.description = read_model_description(str(path))
        self.directory = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self.variables = {v.name: v for v in self.description.modelVariables}

    def names(self, causality, type_name):
        return [v.name for v in self.description.modelVariables if v.causality == causality and v.type == type_name]

    def slave(self, name="test", guid=None, logging_on=False):
        """A new instance (instantiated only) with a recording logger, as `(fmu, logger)`.

        Raises fmpy's exception if fmi2Instantiate returns NULL."""
        logger = RecordingLogger()
        fmu = FMU2Slave(
            guid=self.description.guid if guid is None else guid,
            unzipDirectory=self.directory,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=name,
        )
        fmu.instantiate(callbacks=logger.callbacks, loggingOn=logging_on)
        fmu.logger = logger
        return fmu, logger

    def initialized(self, name="test", reals=None, strings=None, booleans=None):
        """A new instance through initialisation with the given start values."""
        fmu, logger = self.slave(name)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        for values, setter in ((strings, fmu.setString), (booleans, fmu.setBoolean), (reals, fmu.setReal)):
            if values:
                setter([self.vr[n] for n in values], list(values.values()))
        fmu.exitInitializationMode()
        return fmu, logger

    def close(self):
        shutil.rmtree(self.directory, ignore_errors=True)
