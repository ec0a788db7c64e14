/* A small FMI 2.0 model-exchange FMU for the tests (tests/graybox/models/test_fmu.py).

   A heater element and a probe near it, in kelvin above the ambient:

       der(heater.T) = (gain * power - heater.T) / tau     gain = 0.05 K/W (a constant)
       der(probe.T)  = (heater.T - probe.T) / lag
       reading       = probe.T + 0.2 * heater.T             (the only output)

   Both states are hidden. tau is a tunable parameter (s), > 0, lag a fixed one (s), which
   this FMU, like a strict exporter, refuses to change once initialised. It evaluates its
   equations on every get, so any state, input and parameter set is seen at once. Like a
   Modelica assert, a heater above 1000 K is an error (fmi2Error) of fmi2GetDerivatives. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef GUID   /* -DGUID=... builds a re-export: the same equations under another GUID */
#define GUID "{8c4e810f-3df3-4a00-8276-176fa3c9128f}"
#endif
#define GAIN 0.05

enum { VR_HEATER, VR_DER_HEATER, VR_PROBE, VR_DER_PROBE, VR_POWER, VR_READING, VR_TAU, VR_LAG,
       N_VR };
enum { INSTANTIATED, INITIALISING, EVENT_MODE, CONTINUOUS_TIME, TERMINATED };

typedef struct {
    double value[N_VR];
    int mode;
    const fmi2CallbackFunctions *functions;
    fmi2String name;
} Plant;

static void evaluate(Plant *p) {
    double *v = p->value;
    v[VR_DER_HEATER] = (GAIN * v[VR_POWER] - v[VR_HEATER]) / v[VR_TAU];
    v[VR_DER_PROBE] = (v[VR_HEATER] - v[VR_PROBE]) / v[VR_LAG];
    v[VR_READING] = v[VR_PROBE] + 0.2 * v[VR_HEATER];
}

static fmi2Status refuse(Plant *p, const char *message) {
    if (p->functions && p->functions->logger)
        p->functions->logger(p->functions->componentEnvironment, p->name, fmi2Error, "error",
                             message);
    return fmi2Error;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                               const fmi2String categories[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                              fmi2String resources, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean logging) {
    if (type != fmi2ModelExchange || guid == NULL || strcmp(guid, GUID) != 0) return NULL;
    Plant *p = calloc(1, sizeof(Plant));
    if (p == NULL) return NULL;
    p->functions = functions;
    p->name = name;
    p->value[VR_TAU] = 20.0;
    p->value[VR_LAG] = 5.0;
    p->mode = INSTANTIATED;
    evaluate(p);
    return p;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) { return fmi2OK; }

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ((Plant *)c)->mode = INITIALISING;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    ((Plant *)c)->mode = EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ((Plant *)c)->mode = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) { return fmi2Error; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Plant *p = c;
    evaluate(p);
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_VR) return refuse(p, "unknown value reference");
        value[i] = p->value[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Plant *p = c;
    for (size_t i = 0; i < nvr; i++) {
        fmi2ValueReference r = vr[i];
        if (r == VR_DER_HEATER || r == VR_DER_PROBE || r == VR_READING || r >= N_VR)
            return refuse(p, "a derivative or output cannot be set");
        if (r == VR_LAG && p->mode != INSTANTIATED && p->mode != INITIALISING)
            return refuse(p, "lag is a fixed parameter: set it before initialisation");
        if (r == VR_TAU && !(value[i] > 0.0)) return refuse(p, "tau must be > 0");
        p->value[r] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) { return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) { return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) { return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) { return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) { return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) { return nvr ? fmi2Error : fmi2OK; }

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) { return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) { return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) { return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    return fmi2Error;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t size) { return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) { return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[],
                                        size_t nUnknown, const fmi2ValueReference known[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) { return fmi2Error; }

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    ((Plant *)c)->mode = EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    memset(info, 0, sizeof(*info));
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    ((Plant *)c)->mode = CONTINUOUS_TIME;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePrior,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) { return fmi2OK; }

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Plant *p = c;
    if (nx != 2) return refuse(p, "the plant has 2 continuous states");
    p->value[VR_HEATER] = x[0];
    p->value[VR_PROBE] = x[1];
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Plant *p = c;
    if (nx != 2) return refuse(p, "the plant has 2 continuous states");
    if (p->value[VR_HEATER] > 1000.0) return refuse(p, "heater.T above its 1000 K limit");
    evaluate(p);
    derivatives[0] = p->value[VR_DER_HEATER];
    derivatives[1] = p->value[VR_DER_PROBE];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real indicators[], size_t ni) {
    return ni ? fmi2Error : fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Plant *p = c;
    if (nx != 2) return refuse(p, "the plant has 2 continuous states");
    x[0] = p->value[VR_HEATER];
    x[1] = p->value[VR_PROBE];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominals[], size_t nx) {
    for (size_t i = 0; i < nx; i++) nominals[i] = 1.0;
    return fmi2OK;
}
