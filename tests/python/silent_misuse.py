"""Drives the packaged FMUs given on the command line through a misuse sequence with every log
category on and a logger that records instead of printing, and prints nothing itself: the test
that runs it asserts that its stdout and stderr stay empty. Failures are reported through the
exit status and the report file named by the first argument.

Usage: python silent_misuse.py REPORT FMU [FMU ...]
"""

import math
import sys

from fmpy.fmi1 import FMICallException

from fmu_slave import FMI2_ERROR, Packaged


class Failure(Exception):
    pass


def expect_error(call, logger, what):
    try:
        call()
    except FMICallException as e:
        if e.status != FMI2_ERROR:
            raise Failure(f"{what}: status {e.status}, expected fmi2Error")
        if not logger.errors():
            raise Failure(f"{what}: no message through the logger")
        return 1
    raise Failure(f"{what}: the call succeeded")


def misuse(path):
    p = Packaged(path)
    errors = 0
    messages = 0
    try:
        try:
            p.slave(name="%s%n wrong guid", guid="{not-this-fmu}", logging_on=True)
            raise Failure("a wrong GUID was accepted")
        except Failure:
            raise
        except Exception:
            errors += 1

        def verbose(name):
            fmu, logger = p.slave(name=name, logging_on=True)
            fmu.setDebugLogging(True, [])
            return fmu, logger

        fmu, logger = verbose("%s%s%n%p instance")
        errors += expect_error(lambda: fmu.doStep(0.0, 1e-3), logger, "DoStep before initialisation")
        messages += len(logger.messages)
        fmu.freeInstance()

        if "parameter_file" in p.vr:
            fmu, logger = verbose("bad file")
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            errors += expect_error(lambda: fmu.setString([p.vr["parameter_file"]], ["%s%s%n%x.params"]), logger, "bad parameter file")
            messages += len(logger.messages)
            fmu.freeInstance()

        def initialised(name):
            fmu, logger = verbose(name)
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            return fmu, logger

        inputs = p.names("input", "Real")
        if inputs:
            fmu, logger = initialised("nan input")
            errors += expect_error(lambda: fmu.setReal([p.vr[inputs[0]]], [math.nan]), logger, "NaN input")
            messages += len(logger.messages)
            fmu.freeInstance()

        unknown = max(p.vr.values()) + 1
        for what, call in [
            ("unknown value reference", lambda f: f.getReal([unknown])),
            ("negative step", lambda f: f.doStep(0.0, -1e-3)),
            ("wrong communication point", lambda f: f.doStep(0.25, 1e-3)),
        ]:
            fmu, logger = initialised(what)
            errors += expect_error(lambda: call(fmu), logger, what)
            messages += len(logger.messages)
            fmu.freeInstance()

        fmu, logger = initialised("states and termination")
        for k in range(50):
            fmu.doStep(k * 1e-3, 1e-3)
        state = fmu.getFMUstate()
        serialized = fmu.serializeFMUstate(state)
        errors += expect_error(lambda: fmu.deSerializeFMUstate(serialized[: len(serialized) // 3]), logger, "corrupt state")
        fmu.reset()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.terminate()
        errors += expect_error(fmu.terminate, logger, "second Terminate")
        errors += expect_error(lambda: fmu.doStep(0.0, 1e-3), logger, "DoStep after Terminate")
        messages += len(logger.messages)
        fmu.freeFMUstate(state)
        fmu.freeInstance()
    finally:
        p.close()
    return errors, messages


def main():
    report = sys.argv[1]
    errors = messages = 0
    try:
        for path in sys.argv[2:]:
            e, m = misuse(path)
            errors += e
            messages += m
    except Exception as e:  # Any failure goes to the report, never to the console.
        with open(report, "w") as f:
            f.write(f"{type(e).__name__}: {e}")
        return 3
    with open(report, "w") as f:
        f.write(f"{errors} deliberate errors, {messages} messages, all through the logger callback")
    return 0


if __name__ == "__main__":
    sys.exit(main())
