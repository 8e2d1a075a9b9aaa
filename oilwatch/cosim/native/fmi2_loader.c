/*
 * oilwatch FMI 2.0 loader: the binary binaries/linux64/<modelIdentifier>.so of an oilwatch FMU.
 *
 * Why: pythonfmu's export binary (shipped inside the FMU as binaries/linux64/pythonfmu_export.so)
 * does not link libpython and takes the Python environment from whoever loads it, so a host without
 * Python fails with "undefined symbol: _Py_NoneStruct". This loader makes the FMU self-sufficient:
 *
 * 1. On the first fmi2Instantiate it finds a Python environment: the folder OILWATCH_PYTHON_ENV names,
 *    else the build's environment recorded in resources/oilwatch_python.txt (python_env=). That one
 *    folder is the only setting: a virtual environment (its pyvenv.cfg gives the base Python's home and
 *    version; libpython, the standard library and the environment's site-packages follow from them) or
 *    a Python installation prefix (lib/pythonX.Y). Any Python 3.10 or newer with numpy, scipy and numba
 *    will do (pythonfmu's Python part is bundled in resources/); the interpreter must be the
 *    environment's, not the build's, since it is the one
 *    whose packages are installed. A parameter cannot choose it: the interpreter must run before the
 *    FMU's variables exist (fmi2Instantiate), so the setting is an environment variable of the host.
 * 2. If the process has no Python interpreter yet (no Py_IsInitialized symbol in the global scope),
 *    it dlopens that libpython with RTLD_GLOBAL, sets its home, initializes it without signal
 *    handlers (Py_InitializeEx(0): the host keeps SIGINT), puts the environment's site-packages on
 *    sys.path in place of the interpreter's own, and releases the GIL. In a Python host (fmpy,
 *    libcosimpy) none of this happens: the host's interpreter and environment are used, as before.
 *    Either way numpy, scipy and numba must import, and an oilwatch the process already
 *    imported must be the one this FMU bundles (resources/oilwatch/fmu_src/bundle.py, run by path:
 *    the sources' digest); if not, or if a file is missing, the host's logger gets one message naming
 *    what is missing (and OILWATCH_PYTHON_ENV when another environment would help), and fmi2Instantiate
 *    returns NULL.
 * 3. It dlopens pythonfmu_export.so (RTLD_LOCAL) and forwards every fmi2* call to it, with two
 *    changes (below): the status of a refused input, and errors that reach the host's logger always.
 *
 * A refused input. FMI 2.0 (section 4.2.4) lets a fixed parameter be set only before
 * fmi2ExitInitializationMode; the slave (fmu_src/slave_base.py) refuses a later set, leaves the value
 * and the instance untouched and raises. Likewise fmi2ExitInitializationMode fails when the user's
 * parameters are refused (out of range, an unreadable file): only this instance's input is wrong.
 * pythonfmu's wrapper turns every Python exception into fmi2Fatal, which would tell the host that every
 * instance is lost. Before raising, the slave calls this loader's exported oilwatch_loader_refused_call()
 * (found through its resources folder, with ctypes), which flags the current call; a Set* call or
 * fmi2ExitInitializationMode that comes back fmi2Fatal with that flag returns fmi2Error, and pythonfmu's
 * own "Fatal py exception encountered ... unknown error" line for it is dropped (the slave's message,
 * logged first at status error, names the parameter). Any other fatal stays fatal. After a refused set
 * the next fmi2DoStep works (tests/test_fmi_set_status.py).
 *
 * Logging. pythonfmu drops every message, errors included, when the instance was made with
 * loggingOn = fmi2False, so a host that keeps debug logging off would see an error status and no
 * reason. The loader therefore instantiates pythonfmu with logging on, relays each message through its
 * own logger, and passes on messages of status fmi2Error or worse always and the others only while the
 * host has logging on (fmi2Instantiate's loggingOn, then fmi2SetDebugLogging), as the Modelica
 * Association's reference FMUs do.
 *
 * The fast path (the estimator FMU's step). pythonfmu serves every call in Python: it takes the
 * GIL, builds Python lists of the value references and values, calls the slave's method and walks its log
 * queue. A slave that keeps its per-step inputs and outputs in numpy arrays (fmu_src/slave_base.py,
 * "buffered" variables) hands them to the loader during fmi2ExitInitializationMode through the exported
 * oilwatch_loader_bind_buffers() (called with ctypes.PyDLL, the GIL held): the two buffers, a table by
 * value reference (kind and index, or -1) and its step function. Then
 * - fmi2SetReal of bound real inputs, fmi2GetReal of bound reals (inputs or outputs), fmi2GetInteger and
 *   fmi2GetBoolean of bound outputs are served here, in C, without the GIL; a call that names any other
 *   value reference (a parameter, a nuisance output, a wrong type) goes to pythonfmu whole, as before, so
 *   the refusal of a fixed parameter, FMI's type errors and the slave's lazy outputs are unchanged. The
 *   buffers are the slave's own storage of those variables (its attributes read and write them), so
 *   either path sees the same values;
 * - fmi2DoStep writes its time and step size after the inputs, takes the GIL once and calls the step
 *   function, which returns 0 when the step succeeded and logged nothing. Any other outcome (a failed
 *   step, a discard, a queued log message) is replayed through pythonfmu's fmi2DoStep: the slave hands
 *   back the stored outcome without stepping again, and pythonfmu returns the status and relays the
 *   messages exactly as it does without the fast path;
 * - a slave may also hand over a compiled step (oilwatch_loader_bind_plain_step: a C function and its
 *   argument; the estimator's plain sample, fmu_src/ekf_plain_step.py), which fmi2DoStep calls first,
 *   without the GIL: 1 it did the step (fmi2OK), 0 it declined having changed nothing (the Python step
 *   function runs as above), 2 it failed (fmi2Fatal, as pythonfmu answers an exception).
 * fmi2Reset and fmi2FreeInstance drop the binding (pythonfmu's reset makes a new slave object, which binds
 * its own buffers at its next initialization). The slave does not bind with OILWATCH_FMU_FAST_PATH=0. FMI
 * 3.0 and Windows use pythonfmu's binaries, which have no such entry: their slaves stay on the Python path.
 *
 * Teardown. pythonfmu 0.7 keeps its interpreter guard in a static std::shared_ptr and also resets it
 * from an __attribute__((destructor)) function. Its library has STB_GNU_UNIQUE symbols, so dlclose
 * never unloads it; at exit() the C++ static destructor (an atexit entry) runs first and the
 * destructor function afterwards (from _dl_fini), releasing the same control block a second time:
 * "free(): corrupted unsorted chunks" (PythonFMU issues #228, #229). The loader registers, after
 * loading pythonfmu, an atexit handler that calls pythonfmu's exported finalizePythonInterpreter().
 * atexit handlers run in reverse order of registration, so the guard is released once, properly,
 * before the static destructor sees it (already empty). The same handler runs when the host
 * dlcloses this loader. Because the loader initializes the interpreter itself, pythonfmu's guard
 * never calls Py_Finalize (it only finalizes an interpreter it started): unloading one oilwatch FMU
 * cannot finalize Python under another one. The loader never finalizes the interpreter either (numpy
 * cannot be initialized twice in one process); it lives until the process ends, as in a Python host.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <wchar.h>

/* ---- FMI 2.0 types (as in the standard's fmi2TypesPlatform.h / fmi2FunctionTypes.h) ---- */
typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated } fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))
#define INNER_NAME "pythonfmu_export.so"
#define RECORD_NAME "oilwatch_python.txt"

/* ---- the Python C API functions used here, resolved with dlsym ---- */
typedef struct _object PyObject;
typedef int PyGILState_STATE;
static struct {
    int (*IsInitialized)(void);
    void (*InitializeEx)(int);
    void (*SetPythonHome)(const wchar_t *);
    wchar_t *(*DecodeLocale)(const char *, size_t *);
    void *(*EvalSaveThread)(void);
    PyGILState_STATE (*GILStateEnsure)(void);
    void (*GILStateRelease)(PyGILState_STATE);
    PyObject *(*DictNew)(void);
    int (*DictSetItemString)(PyObject *, const char *, PyObject *);
    PyObject *(*DictGetItemString)(PyObject *, const char *);
    PyObject *(*RunString)(const char *, int, PyObject *, PyObject *);
    PyObject *(*UnicodeDecodeFSDefault)(const char *);
    const char *(*UnicodeAsUTF8)(PyObject *);
    PyObject *(*EvalGetBuiltins)(void);
    void (*DecRef)(PyObject *);
    void (*IncRef)(PyObject *);
    void (*ErrClear)(void);
    void (*ErrPrint)(void);
    PyObject *(*CallObject)(PyObject *, PyObject *);
    long (*LongAsLong)(PyObject *);
} py;
#define PY_FILE_INPUT 257

/* Run in the interpreter after start-up: the environment's site-packages replace the interpreter's
 * own (as a virtual environment without system site-packages does), then numpy, scipy and numba must
 * import. Leaves a message in `problem` (empty when all is well). */
static const char CHECK_CODE[] =
    "problem = ''\n"
    "try:\n"
    "    import importlib, importlib.util, os, site, sys\n"
    "    if configure:\n"
    "        own = set(site.getsitepackages() + [site.getusersitepackages()])\n"
    "        sys.path[:] = [p for p in sys.path if p not in own]\n"
    "        for d in [d for d in site_dirs.split(os.pathsep) if d]:\n"
    "            site.addsitedir(d)\n"
    "    missing = []\n"
    "    for name in ('numpy', 'scipy', 'numba'):\n"
    "        try:\n"
    "            importlib.import_module(name)\n"
    "        except Exception as error:\n"
    "            missing.append(f'{name} ({type(error).__name__}: {error})')\n"
    "    if missing:\n"
    "        where = site_dirs if configure else 'the host process\\'s Python (' + sys.prefix + ')'\n"
    "        problem = 'cannot import ' + ', '.join(missing) + ' from ' + where\n"
    "    else:\n"
    "        guard = os.path.join(resources, 'oilwatch', 'fmu_src', 'bundle.py')\n"
    "        if os.path.isfile(guard):\n"
    "            spec = importlib.util.spec_from_file_location('_oilwatch_bundle_guard', guard)\n"
    "            module = importlib.util.module_from_spec(spec)\n"
    "            spec.loader.exec_module(module)\n"
    "            problem = module.admit(resources)\n"
    "            if problem:\n"
    "                problem = 'refused: ' + problem\n"
    "except Exception as error:\n"
    "    problem = f'checking the Python environment failed: {type(error).__name__}: {error}'\n";

/* ---- pythonfmu's binary ---- */
typedef struct {
    void *handle;
    fmi2Component (*Instantiate)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions *,
                                 fmi2Boolean, fmi2Boolean);
    void (*FreeInstance)(fmi2Component);
    fmi2Status (*SetDebugLogging)(fmi2Component, fmi2Boolean, size_t, const fmi2String[]);
    fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
    fmi2Status (*EnterInitializationMode)(fmi2Component);
    fmi2Status (*ExitInitializationMode)(fmi2Component);
    fmi2Status (*Terminate)(fmi2Component);
    fmi2Status (*Reset)(fmi2Component);
    fmi2Status (*GetReal)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[]);
    fmi2Status (*GetInteger)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Integer[]);
    fmi2Status (*GetBoolean)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Boolean[]);
    fmi2Status (*GetString)(fmi2Component, const fmi2ValueReference[], size_t, fmi2String[]);
    fmi2Status (*SetReal)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Real[]);
    fmi2Status (*SetInteger)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Integer[]);
    fmi2Status (*SetBoolean)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Boolean[]);
    fmi2Status (*SetString)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2String[]);
    fmi2Status (*GetFMUstate)(fmi2Component, fmi2FMUstate *);
    fmi2Status (*SetFMUstate)(fmi2Component, fmi2FMUstate);
    fmi2Status (*FreeFMUstate)(fmi2Component, fmi2FMUstate *);
    fmi2Status (*SerializedFMUstateSize)(fmi2Component, fmi2FMUstate, size_t *);
    fmi2Status (*SerializeFMUstate)(fmi2Component, fmi2FMUstate, fmi2Byte[], size_t);
    fmi2Status (*DeSerializeFMUstate)(fmi2Component, const fmi2Byte[], size_t, fmi2FMUstate *);
    fmi2Status (*GetDirectionalDerivative)(fmi2Component, const fmi2ValueReference[], size_t,
                                           const fmi2ValueReference[], size_t, const fmi2Real[], fmi2Real[]);
    fmi2Status (*SetRealInputDerivatives)(fmi2Component, const fmi2ValueReference[], size_t,
                                          const fmi2Integer[], const fmi2Real[]);
    fmi2Status (*GetRealOutputDerivatives)(fmi2Component, const fmi2ValueReference[], size_t,
                                           const fmi2Integer[], fmi2Real[]);
    fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
    fmi2Status (*CancelStep)(fmi2Component);
    fmi2Status (*GetStatus)(fmi2Component, const fmi2StatusKind, fmi2Status *);
    fmi2Status (*GetRealStatus)(fmi2Component, const fmi2StatusKind, fmi2Real *);
    fmi2Status (*GetIntegerStatus)(fmi2Component, const fmi2StatusKind, fmi2Integer *);
    fmi2Status (*GetBooleanStatus)(fmi2Component, const fmi2StatusKind, fmi2Boolean *);
    fmi2Status (*GetStringStatus)(fmi2Component, const fmi2StatusKind, fmi2String *);
} Inner;

static Inner inner;
static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;

typedef struct {
    char python_lib[PATH_MAX];
    char python_home[PATH_MAX];
    char site_dirs[4 * PATH_MAX];
    char python_version[32];
    char env[PATH_MAX];        /* the environment folder, as set or recorded */
    char origin[PATH_MAX + 64]; /* where env came from, for messages */
    int is_venv;               /* a virtual environment: its site-packages replace the interpreter's own */
} Record;

static void report(const fmi2CallbackFunctions *functions, fmi2String instance, const char *format, ...)
{
    char message[8192];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    /* the FMI logger takes a printf format: no '%' may reach it unescaped */
    for (char *p = message; *p; ++p)
        if (*p == '%') *p = ' ';
    if (functions && functions->logger)
        functions->logger(functions->componentEnvironment, instance, fmi2Error, "logStatusError", message);
    else
        fprintf(stderr, "%s: %s\n", instance ? instance : "oilwatch FMU", message);
}

static int is_dir(const char *path)
{
    struct stat info;
    return stat(path, &info) == 0 && S_ISDIR(info.st_mode);
}

static int is_file(const char *path)
{
    struct stat info;
    return stat(path, &info) == 0 && S_ISREG(info.st_mode);
}

/* fmuResourceLocation is a file URI (file:///a/b or file:/a/b, %xx escaped); returns a plain path. */
static int uri_to_path(const char *uri, char *path, size_t size)
{
    if (!uri) return 0;
    if (strncmp(uri, "file://", 7) == 0) uri += 7;
    else if (strncmp(uri, "file:", 5) == 0) uri += 5;
    size_t n = 0;
    for (const char *p = uri; *p && n + 1 < size; ++p) {
        if (p[0] == '%' && p[1] && p[2]) {
            char hex[3] = {p[1], p[2], 0};
            path[n++] = (char)strtol(hex, NULL, 16);
            p += 2;
        } else {
            path[n++] = *p;
        }
    }
    path[n] = 0;
    while (n > 1 && path[n - 1] == '/') path[--n] = 0;
    return n > 0;
}

static void copy_value(char *dst, size_t size, const char *value)
{
    snprintf(dst, size, "%s", value);
    size_t n = strlen(dst);
    while (n && (dst[n - 1] == '\n' || dst[n - 1] == '\r')) dst[--n] = 0;
}

/* The value of `key` in a "key = value" file (pyvenv.cfg), into `value`; 1 when found. */
static int config_value(const char *path, const char *key, char *value, size_t size)
{
    FILE *file = fopen(path, "r");
    if (!file) return 0;
    char line[PATH_MAX + 64];
    int found = 0;
    while (!found && fgets(line, sizeof line, file)) {
        char *eq = strchr(line, '=');
        if (!eq) continue;
        char *end = eq;
        while (end > line && (end[-1] == ' ' || end[-1] == '\t')) --end;
        *end = 0;
        if (strcmp(line, key)) continue;
        const char *start = eq + 1;
        while (*start == ' ' || *start == '\t') ++start;
        copy_value(value, size, start);
        found = 1;
    }
    fclose(file);
    return found;
}

/* "3.12.1" -> "3.12"; 0 when it is not a version string of Python 3.10 or newer. */
static int minor_version(const char *full, char *version, size_t size)
{
    int major = 0, minor = 0;
    if (sscanf(full, "%d.%d", &major, &minor) != 2) return 0;
    snprintf(version, size, "%d.%d", major, minor);
    return major == 3 && minor >= 10;
}

/* The Python version of an installation prefix: the lib/python3.X folder holding os.py (newest first). */
static int prefix_version(const char *prefix, char *version, size_t size)
{
    for (int minor = 40; minor >= 10; --minor) {
        char os_py[PATH_MAX + 64];
        snprintf(os_py, sizeof os_py, "%s/lib/python3.%d/os.py", prefix, minor);
        if (is_file(os_py)) {
            snprintf(version, size, "3.%d", minor);
            return 1;
        }
    }
    return 0;
}

/* The shared libpython of the Python at `prefix` (lib, Debian's multiarch lib, lib64). */
static int find_libpython(const char *prefix, const char *version, char *path, size_t size)
{
    static const char *folders[] = {"lib", "lib/x86_64-linux-gnu", "lib64"};
    static const char *suffixes[] = {".so.1.0", ".so"};
    for (size_t f = 0; f < sizeof folders / sizeof *folders; ++f)
        for (size_t s = 0; s < sizeof suffixes / sizeof *suffixes; ++s) {
            snprintf(path, size, "%s/%s/libpython%s%s", prefix, folders[f], version, suffixes[s]);
            if (is_file(path)) return 1;
        }
    snprintf(path, size, "%s/lib/libpython%s.so", prefix, version);
    return 0;
}

/* Which Python environment to use (top of the file) and what follows from it. */
static int read_record(const char *resources, Record *record, char *error, size_t size)
{
    memset(record, 0, sizeof *record);
    const char *env = getenv("OILWATCH_PYTHON_ENV");
    if (env && *env) {
        copy_value(record->env, sizeof record->env, env);
        snprintf(record->origin, sizeof record->origin, "OILWATCH_PYTHON_ENV");
    } else {
        char path[PATH_MAX + 64];
        snprintf(path, sizeof path, "%s/%s", resources, RECORD_NAME);
        if (!config_value(path, "python_env", record->env, sizeof record->env)) {
            snprintf(error, size,
                     "no Python environment: set OILWATCH_PYTHON_ENV to a virtual environment with numpy, "
                     "scipy and numba (%s names none)",
                     path);
            return 0;
        }
        snprintf(record->origin, sizeof record->origin, "the build's, in resources/%s", RECORD_NAME);
    }
    size_t n = strlen(record->env);
    while (n > 1 && record->env[n - 1] == '/') record->env[--n] = 0;
    if (!is_dir(record->env)) {
        snprintf(error, size,
                 "the Python environment '%s' (%s) does not exist: set OILWATCH_PYTHON_ENV to a virtual "
                 "environment (Python 3.10 or newer) with numpy, scipy and numba",
                 record->env, record->origin);
        return 0;
    }
    char cfg[PATH_MAX + 64], full[64] = "";
    snprintf(cfg, sizeof cfg, "%s/pyvenv.cfg", record->env);
    if (is_file(cfg)) {
        char home[PATH_MAX] = "";
        record->is_venv = 1;
        if (!config_value(cfg, "home", home, sizeof home)) {
            snprintf(error, size, "%s has no 'home' line: recreate the environment with python -m venv", cfg);
            return 0;
        }
        if (!config_value(cfg, "version_info", full, sizeof full)) config_value(cfg, "version", full, sizeof full);
        /* home is the base Python's bin folder; its installation prefix is the folder above */
        n = strlen(home);
        while (n > 1 && home[n - 1] == '/') home[--n] = 0;
        char *slash = strrchr(home, '/');
        if (slash && !strcmp(slash, "/bin")) *slash = 0;
        copy_value(record->python_home, sizeof record->python_home, home);
        if (!full[0] || !minor_version(full, record->python_version, sizeof record->python_version)) {
            snprintf(error, size,
                     "the Python environment '%s' is made by Python '%s' (%s): oilwatch FMUs need Python 3.10 "
                     "or newer; set OILWATCH_PYTHON_ENV to another",
                     record->env, full[0] ? full : "of unknown version", cfg);
            return 0;
        }
        snprintf(record->site_dirs, sizeof record->site_dirs, "%s/lib/python%s/site-packages", record->env,
                 record->python_version);
    } else {
        copy_value(record->python_home, sizeof record->python_home, record->env);
        if (!prefix_version(record->env, record->python_version, sizeof record->python_version)) {
            snprintf(error, size,
                     "'%s' (%s) is neither a virtual environment (no pyvenv.cfg) nor a Python 3.10 or newer "
                     "installation (no lib/python3.X/os.py): set OILWATCH_PYTHON_ENV to one",
                     record->env, record->origin);
            return 0;
        }
        snprintf(record->site_dirs, sizeof record->site_dirs, "%s/lib/python%s/site-packages", record->env,
                 record->python_version);
    }
    find_libpython(record->python_home, record->python_version, record->python_lib, sizeof record->python_lib);
    return 1;
}

static void *symbol(void *handle, const char *name, char *missing, size_t size)
{
    void *address = dlsym(handle, name);
    if (!address && !missing[0]) snprintf(missing, size, "%s", name);
    return address;
}

static int resolve_python(void *handle, char *error, size_t size)
{
    char missing[128] = "";
#define PY(field, name) *(void **)(&py.field) = symbol(handle, name, missing, sizeof missing)
    PY(IsInitialized, "Py_IsInitialized");
    PY(InitializeEx, "Py_InitializeEx");
    PY(DecodeLocale, "Py_DecodeLocale");
    PY(EvalSaveThread, "PyEval_SaveThread");
    PY(GILStateEnsure, "PyGILState_Ensure");
    PY(GILStateRelease, "PyGILState_Release");
    PY(DictNew, "PyDict_New");
    PY(DictSetItemString, "PyDict_SetItemString");
    PY(DictGetItemString, "PyDict_GetItemString");
    PY(RunString, "PyRun_String");
    PY(UnicodeDecodeFSDefault, "PyUnicode_DecodeFSDefault");
    PY(UnicodeAsUTF8, "PyUnicode_AsUTF8");
    PY(EvalGetBuiltins, "PyEval_GetBuiltins");
    PY(DecRef, "Py_DecRef");
    PY(IncRef, "Py_IncRef");
    PY(ErrClear, "PyErr_Clear");
    PY(ErrPrint, "PyErr_Print");
    PY(CallObject, "PyObject_CallObject");
    PY(LongAsLong, "PyLong_AsLong");
#undef PY
    *(void **)(&py.SetPythonHome) = dlsym(handle, "Py_SetPythonHome"); /* optional: PYTHONHOME otherwise */
    if (missing[0]) {
        snprintf(error, size, "the Python runtime lacks the C API function %s", missing);
        return 0;
    }
    return 1;
}

/* Start the interpreter in a process that has none: the record's libpython and home. *started tells
 * whether this call initialized it (then the record's environment goes on sys.path). */
static int start_python(const Record *record, int *started, char *error, size_t size)
{
    if (!is_file(record->python_lib)) {
        snprintf(error, size,
                 "the Python %s of environment '%s' has no shared runtime library (%s is missing): "
                 "make the environment with a Python built with --enable-shared (Debian: libpython%s), or set "
                 "OILWATCH_PYTHON_ENV to another",
                 record->python_version, record->env, record->python_lib, record->python_version);
        return 0;
    }
    char encodings[PATH_MAX + 64];
    snprintf(encodings, sizeof encodings, "%s/lib/python%s/encodings/__init__.py", record->python_home,
             record->python_version);
    if (!is_file(encodings)) {
        /* Py_InitializeEx would abort the host on a home without the standard library */
        snprintf(error, size,
                 "the Python %s of environment '%s' has no standard library (%s is missing): set "
                 "OILWATCH_PYTHON_ENV to an environment whose base Python is installed here",
                 record->python_version, record->env, encodings);
        return 0;
    }
    if (record->is_venv && !is_dir(record->site_dirs)) {
        snprintf(error, size,
                 "the Python environment '%s' has no %s: set OILWATCH_PYTHON_ENV to a virtual environment "
                 "with numpy, scipy and numba",
                 record->env, record->site_dirs);
        return 0;
    }
    void *handle = dlopen(record->python_lib, RTLD_NOW | RTLD_GLOBAL);
    if (!handle) {
        snprintf(error, size, "cannot load the Python runtime of '%s': %s", record->env, dlerror());
        return 0;
    }
    if (!resolve_python(handle, error, size)) return 0;
    if (!py.IsInitialized()) {
        /* Py_SetPythonHome keeps the pointer: the decoded string lives as long as the process */
        wchar_t *home = py.DecodeLocale(record->python_home, NULL);
        if (py.SetPythonHome && home) py.SetPythonHome(home);
        else setenv("PYTHONHOME", record->python_home, 1);
        py.InitializeEx(0);
        py.EvalSaveThread();
        *started = 1;
    }
    return 1;
}

static int check_environment(const Record *record, const char *resources, int started, char *error,
                             size_t size)
{
    PyGILState_STATE gil = py.GILStateEnsure();
    int ok = 0;
    PyObject *globals = py.DictNew();
    PyObject *dirs = py.UnicodeDecodeFSDefault(record->site_dirs);
    PyObject *folder = py.UnicodeDecodeFSDefault(resources);
    /* a started virtual environment: its site-packages replace the base interpreter's own */
    PyObject *flag = py.RunString(started && record->is_venv ? "True" : "False", 258 /* Py_eval_input */,
                                  globals, globals);
    if (globals && dirs && folder && flag) {
        py.DictSetItemString(globals, "__builtins__", py.EvalGetBuiltins());
        py.DictSetItemString(globals, "site_dirs", dirs);
        py.DictSetItemString(globals, "resources", folder);
        py.DictSetItemString(globals, "configure", flag);
        PyObject *result = py.RunString(CHECK_CODE, PY_FILE_INPUT, globals, globals);
        PyObject *problem = py.DictGetItemString(globals, "problem"); /* borrowed */
        const char *text = problem ? py.UnicodeAsUTF8(problem) : NULL;
        if (!result || !text) snprintf(error, size, "the Python environment check could not run");
        else if (!strncmp(text, "refused: ", 9)) snprintf(error, size, "%s", text + 9);
        else if (text[0] && started) {
            snprintf(error, size,
                     "%s: set OILWATCH_PYTHON_ENV to a virtual environment (Python 3.10 or newer) with numpy, "
                     "scipy and numba",
                     text);
        } else if (text[0]) {
            snprintf(error, size, "%s: install numpy, scipy and numba into the Python that runs the host",
                     text);
        } else ok = 1;
        if (result) py.DecRef(result);
    } else {
        snprintf(error, size, "the Python environment check could not start");
    }
    py.ErrClear();
    if (flag) py.DecRef(flag);
    if (folder) py.DecRef(folder);
    if (dirs) py.DecRef(dirs);
    if (globals) py.DecRef(globals);
    py.GILStateRelease(gil);
    return ok;
}

static void release_pythonfmu(void)
{
    void (*finalize)(void) = inner.handle ? (void (*)(void))dlsym(inner.handle, "finalizePythonInterpreter") : NULL;
    if (finalize) finalize();
}

static int load_inner(char *error, size_t size)
{
    Dl_info self;
    if (!dladdr((void *)&load_inner, &self) || !self.dli_fname) {
        snprintf(error, size, "cannot locate the FMU's own binary");
        return 0;
    }
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s", self.dli_fname);
    char *slash = strrchr(path, '/');
    snprintf(slash ? slash + 1 : path, sizeof path - (slash ? (size_t)(slash + 1 - path) : 0), "%s", INNER_NAME);
    void *handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        snprintf(error, size, "cannot load pythonfmu's binary: %s", dlerror());
        return 0;
    }
    char missing[128] = "";
#define FN(field) *(void **)(&inner.field) = symbol(handle, "fmi2" #field, missing, sizeof missing)
    FN(Instantiate); FN(FreeInstance); FN(SetDebugLogging); FN(SetupExperiment);
    FN(EnterInitializationMode); FN(ExitInitializationMode); FN(Terminate); FN(Reset);
    FN(GetReal); FN(GetInteger); FN(GetBoolean); FN(GetString);
    FN(SetReal); FN(SetInteger); FN(SetBoolean); FN(SetString);
    FN(GetFMUstate); FN(SetFMUstate); FN(FreeFMUstate);
    FN(SerializedFMUstateSize); FN(SerializeFMUstate); FN(DeSerializeFMUstate);
    FN(GetDirectionalDerivative); FN(SetRealInputDerivatives); FN(GetRealOutputDerivatives);
    FN(DoStep); FN(CancelStep); FN(GetStatus); FN(GetRealStatus); FN(GetIntegerStatus);
    FN(GetBooleanStatus); FN(GetStringStatus);
#undef FN
    if (missing[0]) {
        snprintf(error, size, "pythonfmu's binary %s lacks %s", path, missing);
        return 0;
    }
    inner.handle = handle;
    atexit(release_pythonfmu); /* after pythonfmu's own static destructors were registered: runs first */
    return 1;
}

static int ensure_loaded(fmi2String resource_location, char *error, size_t size)
{
    char resources[PATH_MAX];
    Record record;
    if (!uri_to_path(resource_location, resources, sizeof resources)) {
        snprintf(error, size, "fmuResourceLocation is empty");
        return 0;
    }
    memset(&record, 0, sizeof record);
    int (*initialized)(void) = (int (*)(void))dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    int started = 0;
    if (initialized && initialized()) { /* the host's Python: no environment to find */
        if (!resolve_python(RTLD_DEFAULT, error, size)) return 0;
    } else if (!read_record(resources, &record, error, size) || !start_python(&record, &started, error, size)) {
        return 0;
    }
    if (!check_environment(&record, resources, started, error, size)) return 0;
    return inner.handle || load_inner(error, size);
}

/* ---- the fast path's binding (top of the file); the kinds as in fmu_src/slave_base.py ---- */
enum { SLOT_REAL_INPUT = 1, SLOT_REAL_OUTPUT = 2, SLOT_INTEGER_OUTPUT = 3, SLOT_BOOLEAN_OUTPUT = 4 };
#define SLOT_SHIFT 24
typedef struct {
    double *inputs;    /* the bound real inputs, then the step's current time and step size */
    size_t n_inputs;
    double *outputs;   /* the bound outputs, integers and booleans as doubles */
    size_t n_outputs;
    int *slots;        /* by value reference: kind << SLOT_SHIFT | index into its buffer, or -1 */
    size_t n_slots;
    PyObject *step;    /* the slave's step function (a reference held here); NULL: not bound */
    int (*kernel)(void *); /* a compiled step tried first, without the GIL (1 done, 0 declined, 2 failed) */
    void *kernel_table;    /* its argument (the slave keeps it alive) */
} FastPath;

/* ---- one instance: pythonfmu's component, the host's callbacks and the relay given to pythonfmu ---- */
typedef struct {
    fmi2Component component;         /* pythonfmu's */
    fmi2CallbackFunctions host;      /* as the host passed them */
    fmi2CallbackFunctions relay;     /* what pythonfmu gets: relay_log, componentEnvironment = this */
    int host_logging;                /* the host's loggingOn / fmi2SetDebugLogging */
    FastPath fast;
} Instance;

/* The instance whose fmi2ExitInitializationMode runs on this thread: the one a slave binds to. */
static __thread Instance *initializing;

/* Called by the slave with the GIL held (ctypes.PyDLL); 1: bound, 0: not (no initialization running here,
 * bad arguments or no memory: the slave stays on the Python path). The buffers belong to the slave, which
 * the held step function keeps alive. */
EXPORT int oilwatch_loader_bind_buffers(double *inputs, size_t n_inputs, double *outputs, size_t n_outputs,
                                        const int *slots, size_t n_slots, PyObject *step)
{
    Instance *self = initializing;
    if (!self || !inputs || !outputs || !slots || !step) return 0;
    for (size_t i = 0; i < n_slots; ++i) {
        int kind = slots[i] < 0 ? 0 : slots[i] >> SLOT_SHIFT, index = slots[i] & ((1 << SLOT_SHIFT) - 1);
        if (slots[i] >= 0 && (kind < SLOT_REAL_INPUT || kind > SLOT_BOOLEAN_OUTPUT ||
                              (size_t)index >= (kind == SLOT_REAL_INPUT ? n_inputs : n_outputs)))
            return 0;
    }
    int *copy = malloc((n_slots ? n_slots : 1) * sizeof *copy);
    if (!copy) return 0;
    memcpy(copy, slots, n_slots * sizeof *copy);
    py.IncRef(step);
    if (self->fast.step) py.DecRef(self->fast.step); /* a second initialization of the same slave */
    free(self->fast.slots);
    self->fast = (FastPath){inputs, n_inputs, outputs, n_outputs, copy, n_slots, step};
    return 1;
}

/* Called by the slave with the GIL held, after oilwatch_loader_bind_buffers in the same initialization: a
 * compiled step (fmu_src/ekf_plain_step.py) that fmi2DoStep calls first, without the GIL. It returns 1 when
 * it did the step, 0 when it declined having changed nothing (the slave's Python step then runs), 2 when
 * it failed. 1: bound, 0: not. */
EXPORT int oilwatch_loader_bind_plain_step(int (*kernel)(void *), void *table)
{
    Instance *self = initializing;
    if (!self || !self->fast.step || !kernel || !table) return 0;
    self->fast.kernel = kernel;
    self->fast.kernel_table = table;
    return 1;
}

/* Whether the instance c serves its bound variables here (for tests and diagnostics). */
EXPORT int oilwatch_loader_fast_path(fmi2Component c) { return c && ((Instance *)c)->fast.step != NULL; }

/* Whether the instance c has a compiled step bound (for tests and diagnostics). */
EXPORT int oilwatch_loader_compiled_step(fmi2Component c) { return c && ((Instance *)c)->fast.kernel != NULL; }

static void unbind(Instance *self)
{
    if (self->fast.step) {
        PyGILState_STATE gil = py.GILStateEnsure();
        py.DecRef(self->fast.step);
        py.GILStateRelease(gil);
    }
    free(self->fast.slots);
    memset(&self->fast, 0, sizeof self->fast);
}

/* The bound value of vr if its kind is one of `kinds` (a bit mask of 1 << kind), else NULL. */
static inline double *bound(const FastPath *fast, fmi2ValueReference vr, unsigned kinds)
{
    if (vr >= fast->n_slots || fast->slots[vr] < 0) return NULL;
    int kind = fast->slots[vr] >> SLOT_SHIFT, index = fast->slots[vr] & ((1 << SLOT_SHIFT) - 1);
    if (!(kinds & (1u << kind))) return NULL;
    return (kind == SLOT_REAL_INPUT ? fast->inputs : fast->outputs) + index;
}

/* Whether every one of the n value references is bound with one of `kinds`. */
static int all_bound(const FastPath *fast, const fmi2ValueReference vr[], size_t n, unsigned kinds)
{
    if (!fast->step || (n && !vr)) return 0;
    for (size_t i = 0; i < n; ++i)
        if (!bound(fast, vr[i], kinds)) return 0;
    return 1;
}

/* Set by the slave (oilwatch_loader_refused_call) during the call whose input it refuses; the call runs
 * on the host's thread, and the slave's Python code on the same thread. */
static __thread int refused_in_call;

EXPORT void oilwatch_loader_refused_call(void) { refused_in_call = 1; }

static void relay_log(fmi2ComponentEnvironment environment, fmi2String name, fmi2Status status,
                      fmi2String category, fmi2String message, ...)
{
    const Instance *self = environment;
    if (!self || !self->host.logger) return;
    if (refused_in_call && status == fmi2Fatal) return; /* pythonfmu's line for the refused call */
    if (status < fmi2Error && !self->host_logging) return;
    /* pythonfmu (cppfmu's Logger::Log) passes the slave's message as the format with no arguments and
     * unescaped: it is text, taken verbatim (a '%' in it, "150 % of q_t", is no conversion) */
    char escaped[2 * 8192];
    const char *text = message ? message : "";
    size_t n = 0; /* the host's logger takes a printf format */
    for (const char *p = text; *p && n + 2 < sizeof escaped; ++p) {
        if (*p == '%') escaped[n++] = '%';
        escaped[n++] = *p;
    }
    escaped[n] = 0;
    self->host.logger(self->host.componentEnvironment, name, status, category, escaped);
}

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                     fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                                     fmi2Boolean visible, fmi2Boolean loggingOn)
{
    char error[6144] = "";
    pthread_mutex_lock(&load_lock);
    int ok = ensure_loaded(fmuResourceLocation, error, sizeof error);
    pthread_mutex_unlock(&load_lock);
    if (!ok) {
        report(functions, instanceName, "oilwatch FMU loader: %s", error);
        return NULL;
    }
    Instance *self = calloc(1, sizeof *self);
    if (!self) {
        report(functions, instanceName, "oilwatch FMU loader: out of memory");
        return NULL;
    }
    if (functions) self->host = *functions;
    self->relay = self->host;
    self->relay.logger = relay_log;
    self->relay.componentEnvironment = self;
    self->relay.stepFinished = NULL; /* pythonfmu steps synchronously: it never calls stepFinished */
    self->host_logging = loggingOn;
    self->component = inner.Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation, &self->relay,
                                        visible, 1);
    if (!self->component) {
        free(self);
        return NULL;
    }
    return self;
}

EXPORT void fmi2FreeInstance(fmi2Component c)
{
    Instance *self = c;
    if (!self) return;
    unbind(self);
    if (inner.FreeInstance) inner.FreeInstance(self->component);
    free(self);
}

EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[])
{
    Instance *self = c;
    if (!self || !inner.SetDebugLogging) return fmi2Error;
    self->host_logging = on;
    /* pythonfmu keeps logging (relay_log filters); the host's categories apply while it has logging on */
    return on ? inner.SetDebugLogging(self->component, 1, n, categories)
              : inner.SetDebugLogging(self->component, 1, 0, NULL);
}

/* Every other function takes the loader's instance and is forwarded with pythonfmu's component. FORWARD_TO
 * defines `declaration params` forwarding to pythonfmu's `field`; FORWARD exports it as fmi2<field>, and
 * FORWARD_INNER keeps it static as forward_<field> (for the calls with a fast path, at the end). */
#define FORWARD_TO(declaration, field, params, args)                                                          \
    declaration params                                                                                         \
    {                                                                                                          \
        if (!c || !inner.field) return fmi2Error;                                                              \
        c = ((Instance *)c)->component;                                                                        \
        return inner.field args;                                                                               \
    }
#define FORWARD(name, params, args) FORWARD_TO(EXPORT fmi2Status fmi2##name, name, params, args)
#define FORWARD_INNER(name, params, args) FORWARD_TO(static fmi2Status forward_##name, name, params, args)
/* The calls that can refuse the user's input: a fatal status after the slave flagged the refusal is
 * fmi2Error (top of the file). */
#define FORWARD_REFUSABLE_TO(declaration, name, params, args)                                                 \
    declaration params                                                                                         \
    {                                                                                                          \
        if (!c || !inner.name) return fmi2Error;                                                               \
        c = ((Instance *)c)->component;                                                                        \
        refused_in_call = 0;                                                                                   \
        fmi2Status status = inner.name args;                                                                   \
        if (status == fmi2Fatal && refused_in_call) status = fmi2Error;                                        \
        refused_in_call = 0;                                                                                   \
        return status;                                                                                         \
    }
#define FORWARD_REFUSABLE(name, params, args)                                                                 \
    FORWARD_REFUSABLE_TO(EXPORT fmi2Status fmi2##name, name, params, args)
#define SET_PARAMS(type) (fmi2Component c, const fmi2ValueReference vr[], size_t n, const type v[])
#define GET_PARAMS(type) (fmi2Component c, const fmi2ValueReference vr[], size_t n, type v[])
#define FORWARD_SET(name, type) FORWARD_REFUSABLE(name, SET_PARAMS(type), (c, vr, n, v))
FORWARD(SetupExperiment, (fmi2Component c, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real start,
                          fmi2Boolean stop_defined, fmi2Real stop),
        (c, tol_defined, tol, start, stop_defined, stop))
FORWARD(EnterInitializationMode, (fmi2Component c), (c))
FORWARD_REFUSABLE_TO(static fmi2Status forward_ExitInitializationMode, ExitInitializationMode,
                     (fmi2Component c), (c))
FORWARD(Terminate, (fmi2Component c), (c))
FORWARD_INNER(GetReal, GET_PARAMS(fmi2Real), (c, vr, n, v))
FORWARD_INNER(GetInteger, GET_PARAMS(fmi2Integer), (c, vr, n, v))
FORWARD_INNER(GetBoolean, GET_PARAMS(fmi2Boolean), (c, vr, n, v))
FORWARD(GetString, GET_PARAMS(fmi2String), (c, vr, n, v))
FORWARD_REFUSABLE_TO(static fmi2Status forward_SetReal, SetReal, SET_PARAMS(fmi2Real), (c, vr, n, v))
FORWARD_SET(SetInteger, fmi2Integer)
FORWARD_SET(SetBoolean, fmi2Boolean)
FORWARD_SET(SetString, fmi2String)
FORWARD(GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FORWARD(SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))
FORWARD(FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FORWARD(SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *n), (c, s, n))
FORWARD(SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n), (c, s, b, n))
FORWARD(DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s), (c, b, n, s))
FORWARD(GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                   const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]),
        (c, u, nu, z, nz, dv, dz))
FORWARD(SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                  const fmi2Integer order[], const fmi2Real v[]),
        (c, vr, n, order, v))
FORWARD(GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                   const fmi2Integer order[], fmi2Real v[]),
        (c, vr, n, order, v))
FORWARD_REFUSABLE_TO(static fmi2Status forward_DoStep, DoStep, (fmi2Component c, fmi2Real t, fmi2Real h,
                     fmi2Boolean no_prior), (c, t, h, no_prior)) /* an input refused at a step, a wrong state */
FORWARD(CancelStep, (fmi2Component c), (c))
FORWARD(GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))
FORWARD(GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))
FORWARD(GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v), (c, k, v))
FORWARD(GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v), (c, k, v))
FORWARD(GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v), (c, k, v))

/* ---- the calls with a fast path (top of the file); the others forward as above ---- */
#define REALS ((1u << SLOT_REAL_INPUT) | (1u << SLOT_REAL_OUTPUT))

EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    initializing = c; /* the slave binds its buffers during this call (oilwatch_loader_bind_buffers) */
    fmi2Status status = forward_ExitInitializationMode(c);
    initializing = NULL;
    return status;
}

EXPORT fmi2Status fmi2Reset(fmi2Component c)
{
    Instance *self = c;
    if (!self || !inner.Reset) return fmi2Error;
    unbind(self); /* pythonfmu's reset makes a new slave object */
    return inner.Reset(self->component);
}

EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    Instance *self = c;
    if (self && all_bound(&self->fast, vr, n, 1u << SLOT_REAL_INPUT)) {
        for (size_t i = 0; i < n; ++i) *bound(&self->fast, vr[i], 1u << SLOT_REAL_INPUT) = v[i];
        return fmi2OK;
    }
    return forward_SetReal(c, vr, n, v);
}

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    Instance *self = c;
    if (self && all_bound(&self->fast, vr, n, REALS)) {
        for (size_t i = 0; i < n; ++i) v[i] = *bound(&self->fast, vr[i], REALS);
        return fmi2OK;
    }
    return forward_GetReal(c, vr, n, v);
}

EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{
    Instance *self = c;
    if (self && all_bound(&self->fast, vr, n, 1u << SLOT_INTEGER_OUTPUT)) {
        for (size_t i = 0; i < n; ++i) v[i] = (fmi2Integer)*bound(&self->fast, vr[i], 1u << SLOT_INTEGER_OUTPUT);
        return fmi2OK;
    }
    return forward_GetInteger(c, vr, n, v);
}

EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{
    Instance *self = c;
    if (self && all_bound(&self->fast, vr, n, 1u << SLOT_BOOLEAN_OUTPUT)) {
        for (size_t i = 0; i < n; ++i) v[i] = *bound(&self->fast, vr[i], 1u << SLOT_BOOLEAN_OUTPUT) != 0.0;
        return fmi2OK;
    }
    return forward_GetBoolean(c, vr, n, v);
}

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior)
{
    Instance *self = c;
    if (self && self->fast.step) {
        self->fast.inputs[self->fast.n_inputs] = t;
        self->fast.inputs[self->fast.n_inputs + 1] = h;
        if (self->fast.kernel) {
            int done = self->fast.kernel(self->fast.kernel_table);
            if (done == 1) return fmi2OK;
            if (done != 0) {
                if (self->host.logger)
                    self->host.logger(self->host.componentEnvironment, "", fmi2Fatal, "logStatusFatal",
                                      "the compiled step failed at t = %.9g s (its exception is on stderr)", t);
                return fmi2Fatal;
            }
        }
        PyGILState_STATE gil = py.GILStateEnsure();
        PyObject *result = py.CallObject(self->fast.step, NULL);
        long outcome = result ? py.LongAsLong(result) : -1;
        if (result) py.DecRef(result);
        else py.ErrPrint(); /* the step function catches everything: this is a bug, on stderr */
        py.ErrClear();
        py.GILStateRelease(gil);
        if (outcome == 0) return fmi2OK;
        if (outcome < 0) return fmi2Fatal;
    }
    return forward_DoStep(c, t, h, no_prior); /* the slave replays a stored outcome (top of the file) */
}
