/*
 * oilwatch FMI 3.0 binary: binaries/x86_64-linux/<modelIdentifier>.so of an oilwatch FMI 3.0 FMU, a thin
 * layer over pythonfmu3's own binary (shipped beside it as <modelIdentifier>_pythonfmu3.so, which this
 * library names as a dependency with the run path $ORIGIN; oilwatch/cosim/native_loader.py builds both).
 *
 * Why: pythonfmu3's C++ wrapper turns every Python exception into fmi3Fatal, "all instances corrupted".
 * When the slave refuses the user's input (a parameter out of range or unreadable at
 * fmi3ExitInitializationMode, a fixed parameter set after it; fmu_src/slave_base.py), only this instance's
 * input was wrong: FMI 3.0 asks for fmi3Error. As in the FMI 2.0 loader (fmi2_loader.c), the slave calls the
 * exported oilwatch_loader_refused_call() (found through its resources folder, with ctypes) before raising;
 * a call that comes back fmi3Fatal with that flag returns fmi3Error, and pythonfmu3's own "Fatal py
 * exception" line for it is dropped (the slave's message, logged first at status error, names the
 * parameter). Any other fatal stays fatal.
 *
 * Only the calls that can refuse input are defined here: fmi3ExitInitializationMode and the fmi3Set* of the
 * types the shells declare (Float64, Int32, Boolean, String), plus fmi3InstantiateCoSimulation and
 * fmi3FreeInstance, which put a relay between pythonfmu3 and the host's logger. Every other fmi3* symbol a
 * host looks up with dlsym on this library's handle is pythonfmu3's, found in this library's dependency
 * (dlsym searches a handle's dependency tree breadth first), so nothing else is forwarded by hand.
 *
 * Teardown. pythonfmu3's binary has pythonfmu 0.7's defect (fmi2_loader.c, "Teardown"): its interpreter
 * guard, a static std::shared_ptr, is released by its static destructor at exit and again by its
 * __attribute__((destructor)) function, the second time through a control block already freed, which
 * corrupts the heap or aborts ("corrupted double-linked list") in any host that does not release the guard
 * itself. pythonfmu3's binary is this library's dependency, so its static constructors, which register that
 * destructor with atexit, have run before this library's constructor, which registers a handler that calls
 * pythonfmu3's exported finalizePythonInterpreter(): atexit handlers run in reverse order, so the guard is
 * released once, properly, and both later releases find it empty. The handler also runs when the host
 * dlcloses this library (glibc runs a library's atexit handlers then); pythonfmu3's binary stays loaded
 * (its STB_GNU_UNIQUE symbols) and makes a new guard at its next instantiation. In a Python host the guard
 * owns no interpreter, so this finalizes nothing.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

/* ---- FMI 3.0 types (as in the standard's fmi3PlatformTypes.h / fmi3FunctionTypes.h) ---- */
typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef uint32_t fmi3ValueReference;
typedef double fmi3Float64;
typedef int32_t fmi3Int32;
typedef bool fmi3Boolean;
typedef const char *fmi3String;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String);
typedef void (*fmi3IntermediateUpdateCallback)(fmi3InstanceEnvironment, fmi3Float64, fmi3Boolean, fmi3Boolean,
                                               fmi3Boolean, fmi3Boolean, fmi3Boolean *, fmi3Float64 *);

#define EXPORT __attribute__((visibility("default")))
#ifndef INNER_NAME /* set by the build: <modelIdentifier>_pythonfmu3.so */
#define INNER_NAME "pythonfmu3_export.so"
#endif

/* pythonfmu3's function of the same name: the next definition after this library in its lookup scope, i.e.
 * in the dependency the dynamic linker bound (the same one the host's other fmi3* lookups reach) */
static void *inner(const char *name) { return dlsym(RTLD_NEXT, name); }

static void (*finalize_inner)(void);

static void release_pythonfmu3(void)
{
    if (finalize_inner) finalize_inner();
}

__attribute__((constructor)) static void register_release(void)
{
    *(void **)(&finalize_inner) = inner("finalizePythonInterpreter");
    if (finalize_inner) atexit(release_pythonfmu3);
}

/* Set by the slave during the call whose input it refuses (same thread as the host's call). */
static __thread int refused_in_call;

EXPORT void oilwatch_loader_refused_call(void) { refused_in_call = 1; }

static fmi3Status mapped(fmi3Status status)
{
    if (refused_in_call && status == fmi3Fatal) status = fmi3Error;
    refused_in_call = 0;
    return status;
}

/* ---- the relay between pythonfmu3 and the host's logger, one per instance ---- */
typedef struct Relay {
    fmi3Instance instance; /* pythonfmu3's */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
    struct Relay *next;
} Relay;

static Relay *relays;
static pthread_mutex_t relays_lock = PTHREAD_MUTEX_INITIALIZER;

static void relay_log(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category,
                      fmi3String message)
{
    const Relay *relay = environment;
    if (!relay || !relay->log) return;
    if (refused_in_call && status == fmi3Fatal) return; /* pythonfmu3's line for the refused call */
    relay->log(relay->environment, status, category, message);
}

typedef fmi3Instance InstantiateFn(fmi3String, fmi3String, fmi3String, fmi3Boolean, fmi3Boolean, fmi3Boolean,
                                   fmi3Boolean, const fmi3ValueReference[], size_t, fmi3InstanceEnvironment,
                                   fmi3LogMessageCallback, fmi3IntermediateUpdateCallback);

EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                                fmi3String resourcePath, fmi3Boolean visible,
                                                fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                                fmi3Boolean earlyReturnAllowed,
                                                const fmi3ValueReference requiredIntermediateVariables[],
                                                size_t nRequiredIntermediateVariables,
                                                fmi3InstanceEnvironment instanceEnvironment,
                                                fmi3LogMessageCallback logMessage,
                                                fmi3IntermediateUpdateCallback intermediateUpdate)
{
    InstantiateFn *next = (InstantiateFn *)inner("fmi3InstantiateCoSimulation");
    Relay *relay = calloc(1, sizeof *relay);
    if (!next || !relay) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Fatal, "logStatusFatal",
                       "oilwatch FMI 3.0 binary: cannot reach pythonfmu3's binary " INNER_NAME);
        free(relay);
        return NULL;
    }
    relay->environment = instanceEnvironment;
    relay->log = logMessage;
    relay->instance = next(instanceName, instantiationToken, resourcePath, visible, loggingOn, eventModeUsed,
                           earlyReturnAllowed, requiredIntermediateVariables, nRequiredIntermediateVariables,
                           relay, relay_log, intermediateUpdate);
    if (!relay->instance) {
        free(relay);
        return NULL;
    }
    pthread_mutex_lock(&relays_lock);
    relay->next = relays;
    relays = relay;
    pthread_mutex_unlock(&relays_lock);
    return relay->instance;
}

EXPORT void fmi3FreeInstance(fmi3Instance instance)
{
    void (*next)(fmi3Instance) = (void (*)(fmi3Instance))inner("fmi3FreeInstance");
    if (next) next(instance);
    pthread_mutex_lock(&relays_lock);
    for (Relay **link = &relays; *link; link = &(*link)->next) {
        if ((*link)->instance == instance) {
            Relay *gone = *link;
            *link = gone->next;
            free(gone);
            break;
        }
    }
    pthread_mutex_unlock(&relays_lock);
}

EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    fmi3Status (*next)(fmi3Instance) = (fmi3Status(*)(fmi3Instance))inner("fmi3ExitInitializationMode");
    refused_in_call = 0;
    return next ? mapped(next(instance)) : fmi3Fatal;
}

#define SETTER(TYPE, NAME)                                                                                    \
    EXPORT fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],                 \
                           size_t nValueReferences, const TYPE values[], size_t nValues)                      \
    {                                                                                                         \
        fmi3Status (*next)(fmi3Instance, const fmi3ValueReference[], size_t, const TYPE[], size_t) =          \
            (fmi3Status(*)(fmi3Instance, const fmi3ValueReference[], size_t, const TYPE[], size_t))inner(#NAME); \
        refused_in_call = 0;                                                                                  \
        return next ? mapped(next(instance, valueReferences, nValueReferences, values, nValues)) : fmi3Fatal; \
    }

SETTER(fmi3Float64, fmi3SetFloat64)
SETTER(fmi3Int32, fmi3SetInt32)
SETTER(fmi3Boolean, fmi3SetBoolean)
SETTER(fmi3String, fmi3SetString)
