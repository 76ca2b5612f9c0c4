/* A minimal FMI 2.0 co-simulation master in C, for running the FMUs' win64 binaries under wine
 * beside their linux64 binaries: it loads one FMU's shared library, instantiates it, sets Real
 * parameters and inputs, initialises, takes fixed steps and prints the chosen Real outputs at
 * every step, one line each, with 17 significant digits. The same source builds natively
 * (dlopen) and with mingw-w64 (LoadLibrary), so that both platforms run the same calls.
 *
 * fmu_master LIBRARY MODEL_NAME GUID RESOURCE_URI STEPS STEP_S [set:VR=VALUE ...] [out:VR ...]
 *
 * Exit codes: 0 every call returned fmi2OK; 1 a call failed (its name on stderr); 2 bad usage. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
typedef HMODULE library_t;
static library_t open_library(const char *path) { return LoadLibraryA(path); }
static void *symbol(library_t library, const char *name) { return (void *)GetProcAddress(library, name); }
#else
#include <dlfcn.h>
typedef void *library_t;
static library_t open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(library_t library, const char *name) { return dlsym(library, name); }
#endif

/* The FMI 2.0 types this master uses (fmi2TypesPlatform.h, fmi2FunctionTypes.h). */
typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Boolean;
typedef const char *fmi2String;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef struct {
    void (*logger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*instantiate_t)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions *,
                                       fmi2Boolean, fmi2Boolean);
typedef fmi2Status (*setup_t)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*plain_t)(fmi2Component);
typedef fmi2Status (*reals_t)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*set_reals_t)(fmi2Component, const fmi2ValueReference *, size_t, const fmi2Real *);
typedef fmi2Status (*step_t)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef void (*free_t)(fmi2Component);

/* The FMUs log through this callback; the master prints errors only. */
static void logger(fmi2ComponentEnvironment environment, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)environment;
    if (status >= fmi2Error) {
        va_list arguments;
        va_start(arguments, message);
        fprintf(stderr, "%s [%s]: ", instance, category);
        vfprintf(stderr, message, arguments);
        fprintf(stderr, "\n");
        va_end(arguments);
    }
}

static void *load(library_t library, const char *name) {
    void *function = symbol(library, name);
    if (!function) {
        fprintf(stderr, "the library has no %s\n", name);
        exit(1);
    }
    return function;
}

static void check(fmi2Status status, const char *call) {
    if (status != fmi2OK) {
        fprintf(stderr, "%s returned %d\n", call, (int)status);
        exit(1);
    }
}

int main(int argc, char **argv) {
    if (argc < 7) {
        fprintf(stderr, "usage: fmu_master LIBRARY MODEL_NAME GUID RESOURCE_URI STEPS STEP_S [set:VR=VALUE ...] [out:VR ...]\n");
        return 2;
    }
    library_t library = open_library(argv[1]);
    if (!library) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 1;
    }
    long steps = strtol(argv[5], NULL, 10);
    double h = strtod(argv[6], NULL);
    fmi2ValueReference set_vrs[256], out_vrs[256];
    fmi2Real set_values[256], out_values[256];
    size_t n_set = 0, n_out = 0;
    for (int i = 7; i < argc; i++) {
        if (strncmp(argv[i], "set:", 4) == 0 && n_set < 256) {
            char *equals = strchr(argv[i], '=');
            if (!equals) return 2;
            set_vrs[n_set] = (fmi2ValueReference)strtoul(argv[i] + 4, NULL, 10);
            set_values[n_set++] = strtod(equals + 1, NULL);
        } else if (strncmp(argv[i], "out:", 4) == 0 && n_out < 256) {
            out_vrs[n_out++] = (fmi2ValueReference)strtoul(argv[i] + 4, NULL, 10);
        } else {
            return 2;
        }
    }
    instantiate_t instantiate = (instantiate_t)load(library, "fmi2Instantiate");
    setup_t setup = (setup_t)load(library, "fmi2SetupExperiment");
    plain_t enter = (plain_t)load(library, "fmi2EnterInitializationMode");
    plain_t leave = (plain_t)load(library, "fmi2ExitInitializationMode");
    plain_t terminate = (plain_t)load(library, "fmi2Terminate");
    set_reals_t set_real = (set_reals_t)load(library, "fmi2SetReal");
    reals_t get_real = (reals_t)load(library, "fmi2GetReal");
    step_t do_step = (step_t)load(library, "fmi2DoStep");
    free_t free_instance = (free_t)load(library, "fmi2FreeInstance");
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate(argv[2], fmi2CoSimulation, argv[3], argv[4], &callbacks, 0, 0);
    if (!c) {
        fprintf(stderr, "fmi2Instantiate returned NULL\n");
        return 1;
    }
    check(setup(c, 0, 0.0, 0.0, 0, 0.0), "fmi2SetupExperiment");
    if (n_set) check(set_real(c, set_vrs, n_set, set_values), "fmi2SetReal");
    check(enter(c), "fmi2EnterInitializationMode");
    check(leave(c), "fmi2ExitInitializationMode");
    for (long k = 0; k < steps; k++) {
        check(do_step(c, (double)k * h, h, 1), "fmi2DoStep");
        if (n_out) {
            check(get_real(c, out_vrs, n_out, out_values), "fmi2GetReal");
            for (size_t j = 0; j < n_out; j++) printf(j ? " %.17g" : "%.17g", out_values[j]);
            printf("\n");
        }
    }
    check(terminate(c), "fmi2Terminate");
    free_instance(c);
    return 0;
}
