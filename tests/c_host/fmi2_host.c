/*
 * A minimal FMI 2.0 co-simulation importer in C, with no Python in it: the oilwatch tests compile it
 * with the system's C compiler and run oilwatch's FMUs with it (tests/test_c_host.py).
 *
 * Usage: fmi2_host SPEC OUT.csv
 *
 * SPEC is a text file, one directive a line:
 *   fmu NAME FOLDER MODEL_IDENTIFIER GUID    an FMU extracted to FOLDER, instance NAME
 *   real NAME VR VALUE                       set a Real before initialization
 *   integer NAME VR VALUE                    set an Integer before initialization
 *   late NAME VR VALUE                       set a Real after initialization, before the first step:
 *                                            its status goes to stderr, and the run goes on after
 *                                            fmi2OK, fmi2Warning or fmi2Error (only Fatal stops it)
 *   connect SRC VR DST VR                    before DST steps, its Real input VR takes SRC's output VR
 *   output NAME VR LABEL                     record a Real output after every step
 *   boolean NAME VR LABEL                    record a Boolean output (0/1) after every step
 *   timing NAME FILE                         time every step of instance NAME: its input sets, doStep
 *                                            and output gets, as CPU time of this thread
 *                                            (CLOCK_THREAD_CPUTIME_ID) and wall time (CLOCK_MONOTONIC);
 *                                            FILE gets "step,cpu_ns,wall_ns" and one row per step
 *   run STOP STEP                            stop time and communication step [s]
 * The FMUs step in the order listed (Gauss-Seidel): step k of each FMU runs from k*STEP, after the
 * FMUs listed before it made that step; an FMU's outputs are read right after its doStep (the
sources' values a connection carries are read before the timed sets begin). OUT.csv gets "time,LABEL..." and one row per step (%.17g:
 * every double round-trips exactly). The FMU logger writes to stderr.
 *
 * Exit codes: 0 every instance freed and every library unloaded after the run; 2 bad usage or spec;
 * 3 a library could not be loaded; 4 fmi2Instantiate returned NULL; 5 an FMI call failed.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *fmi2Component;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef void (*Logger)(void *, const char *, fmi2Status, const char *, const char *, ...);
typedef struct {
    Logger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, fmi2Status);
    void *componentEnvironment;
} Callbacks;

typedef struct {
    char name[64], folder[4096], identifier[256], guid[128];
    void *library;
    fmi2Component instance;
    fmi2Component (*instantiate)(const char *, int, const char *, const char *, const Callbacks *, int, int);
    void (*free_instance)(fmi2Component);
    fmi2Status (*setup)(fmi2Component, int, double, double, int, double);
    fmi2Status (*enter_init)(fmi2Component);
    fmi2Status (*exit_init)(fmi2Component);
    fmi2Status (*terminate)(fmi2Component);
    fmi2Status (*get_real)(fmi2Component, const unsigned[], size_t, double[]);
    fmi2Status (*set_real)(fmi2Component, const unsigned[], size_t, const double[]);
    fmi2Status (*set_integer)(fmi2Component, const unsigned[], size_t, const int[]);
    fmi2Status (*get_boolean)(fmi2Component, const unsigned[], size_t, int[]);
    fmi2Status (*do_step)(fmi2Component, double, double, int);
} Fmu;

typedef struct { int fmu; char kind; unsigned vr; double value; } Parameter;
typedef struct { int src; unsigned src_vr; int dst; unsigned dst_vr; } Connection;
typedef struct { int fmu; unsigned vr; char label[64]; char kind; } Output;

#define MAX 64
static Fmu fmus[8];
static int n_fmus;
static Parameter parameters[MAX];
static int n_parameters;
static Parameter late[MAX];
static int n_late;
static Connection connections[MAX];
static int n_connections;
static Output outputs[MAX];
static int n_outputs;
static int timed_fmu = -1; /* the instance the timing directive names, or -1 */
static char timing_path[4096];

static long long nanoseconds(clockid_t clock)
{
    struct timespec t;
    clock_gettime(clock, &t);
    return (long long)t.tv_sec * 1000000000LL + t.tv_nsec;
}

static const char *STATUS[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};

static void log_message(void *environment, const char *instance, fmi2Status status, const char *category,
                        const char *message, ...)
{
    (void)environment;
    char text[8192];
    va_list args;
    va_start(args, message);
    vsnprintf(text, sizeof text, message, args);
    va_end(args);
    fprintf(stderr, "[%s] %s %s: %s\n", STATUS[status <= fmi2Pending ? status : fmi2Fatal],
            instance ? instance : "?", category ? category : "", text);
}

static int find_fmu(const char *name)
{
    for (int i = 0; i < n_fmus; ++i)
        if (!strcmp(fmus[i].name, name)) return i;
    fprintf(stderr, "spec: unknown FMU instance %s\n", name);
    exit(2);
}

static int read_spec(const char *path, double *stop, double *step)
{
    FILE *file = fopen(path, "r");
    if (!file) return 0;
    char line[8192], a[4096], b[4096], c[256], d[128];
    while (fgets(line, sizeof line, file)) {
        char kind[16];
        if (sscanf(line, "%15s", kind) != 1 || kind[0] == '#') continue;
        if (!strcmp(kind, "fmu") && sscanf(line, "fmu %63s %4095s %255s %127s", a, b, c, d) == 4) {
            Fmu *fmu = &fmus[n_fmus++];
            snprintf(fmu->name, sizeof fmu->name, "%.63s", a);
            snprintf(fmu->folder, sizeof fmu->folder, "%s", b);
            snprintf(fmu->identifier, sizeof fmu->identifier, "%.255s", c);
            snprintf(fmu->guid, sizeof fmu->guid, "%.127s", d);
        } else if (!strcmp(kind, "real") || !strcmp(kind, "integer")) {
            Parameter *p = &parameters[n_parameters];
            if (sscanf(line, "%*s %63s %u %lf", a, &p->vr, &p->value) != 3) break;
            p->fmu = find_fmu(a);
            p->kind = kind[0];
            n_parameters++;
        } else if (!strcmp(kind, "late")) {
            Parameter *p = &late[n_late];
            if (sscanf(line, "late %63s %u %lf", a, &p->vr, &p->value) != 3) break;
            p->fmu = find_fmu(a);
            p->kind = 'r';
            n_late++;
        } else if (!strcmp(kind, "connect")) {
            Connection *k = &connections[n_connections];
            if (sscanf(line, "connect %63s %u %63s %u", a, &k->src_vr, b, &k->dst_vr) != 4) break;
            k->src = find_fmu(a);
            k->dst = find_fmu(b);
            n_connections++;
        } else if (!strcmp(kind, "output") || !strcmp(kind, "boolean")) {
            Output *o = &outputs[n_outputs];
            if (sscanf(line, "%*s %63s %u %63s", a, &o->vr, o->label) != 3) break;
            o->fmu = find_fmu(a);
            o->kind = kind[0];
            n_outputs++;
        } else if (!strcmp(kind, "timing")) {
            if (sscanf(line, "timing %63s %4095s", a, timing_path) != 2) break;
            timed_fmu = find_fmu(a);
        } else if (!strcmp(kind, "run")) {
            if (sscanf(line, "run %lf %lf", stop, step) != 2) break;
        } else {
            fprintf(stderr, "spec: cannot read line: %s", line);
            fclose(file);
            return 0;
        }
    }
    fclose(file);
    return n_fmus > 0 && *step > 0;
}

static int load(Fmu *fmu)
{
    char path[8192];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", fmu->folder, fmu->identifier);
    fmu->library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!fmu->library) {
        fprintf(stderr, "cannot load %s: %s\n", path, dlerror());
        return 0;
    }
#define SYM(field, name)                                                                                      \
    if (!(*(void **)(&fmu->field) = dlsym(fmu->library, name))) {                                            \
        fprintf(stderr, "%s lacks %s\n", path, name);                                                        \
        return 0;                                                                                             \
    }
    SYM(instantiate, "fmi2Instantiate");
    SYM(free_instance, "fmi2FreeInstance");
    SYM(setup, "fmi2SetupExperiment");
    SYM(enter_init, "fmi2EnterInitializationMode");
    SYM(exit_init, "fmi2ExitInitializationMode");
    SYM(terminate, "fmi2Terminate");
    SYM(get_real, "fmi2GetReal");
    SYM(set_real, "fmi2SetReal");
    SYM(set_integer, "fmi2SetInteger");
    SYM(get_boolean, "fmi2GetBoolean");
    SYM(do_step, "fmi2DoStep");
#undef SYM
    return 1;
}

static int check(fmi2Status status, const Fmu *fmu, const char *call, double time)
{
    if (status == fmi2OK || status == fmi2Warning) return 1;
    fprintf(stderr, "%s: %s returned %s at t = %g s\n", fmu->name, call, STATUS[status], time);
    return 0;
}

/* Free every instance and unload every library; returns how many libraries were unloaded. */
static int teardown(void)
{
    int freed = 0, unloaded = 0;
    for (int i = 0; i < n_fmus; ++i) {
        if (fmus[i].instance) {
            fmus[i].free_instance(fmus[i].instance);
            fmus[i].instance = NULL;
            freed++;
        }
    }
    for (int i = 0; i < n_fmus; ++i)
        if (fmus[i].library && dlclose(fmus[i].library) == 0) unloaded++;
    fprintf(stderr, "freed %d instances, unloaded %d libraries\n", freed, unloaded);
    return unloaded;
}

int main(int argc, char **argv)
{
    double stop = 0, step = 0;
    if (argc != 3 || !read_spec(argv[1], &stop, &step)) {
        fprintf(stderr, "usage: fmi2_host SPEC OUT.csv (see the comment in fmi2_host.c)\n");
        return 2;
    }
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized")) {
        fprintf(stderr, "this host must start without Python, but Py_IsInitialized is already loaded\n");
        return 2;
    }
    fprintf(stderr, "no Python in this process before loading the FMUs\n");
    static Callbacks callbacks = {log_message, calloc, free, NULL, NULL};
    for (int i = 0; i < n_fmus; ++i) {
        if (!load(&fmus[i])) {
            teardown();
            return 3;
        }
    }
    for (int i = 0; i < n_fmus; ++i) {
        char uri[8192];
        snprintf(uri, sizeof uri, "file://%s/resources", fmus[i].folder);
        fmus[i].instance = fmus[i].instantiate(fmus[i].name, 1, fmus[i].guid, uri, &callbacks, 0, 0);
        if (!fmus[i].instance) {
            fprintf(stderr, "%s: fmi2Instantiate returned NULL\n", fmus[i].name);
            teardown();
            return 4;
        }
    }
    int ok = 1;
    for (int i = 0; ok && i < n_fmus; ++i) {
        Fmu *fmu = &fmus[i];
        ok = check(fmu->setup(fmu->instance, 0, 0.0, 0.0, 1, stop), fmu, "fmi2SetupExperiment", 0.0);
        for (int p = 0; ok && p < n_parameters; ++p) {
            if (parameters[p].fmu != i) continue;
            if (parameters[p].kind == 'r') {
                ok = check(fmu->set_real(fmu->instance, &parameters[p].vr, 1, &parameters[p].value), fmu,
                           "fmi2SetReal", 0.0);
            } else {
                int value = (int)parameters[p].value;
                ok = check(fmu->set_integer(fmu->instance, &parameters[p].vr, 1, &value), fmu, "fmi2SetInteger",
                           0.0);
            }
        }
        ok = ok && check(fmu->enter_init(fmu->instance), fmu, "fmi2EnterInitializationMode", 0.0);
        ok = ok && check(fmu->exit_init(fmu->instance), fmu, "fmi2ExitInitializationMode", 0.0);
    }
    for (int p = 0; ok && p < n_late; ++p) {
        Fmu *fmu = &fmus[late[p].fmu];
        fmi2Status status = fmu->set_real(fmu->instance, &late[p].vr, 1, &late[p].value);
        fprintf(stderr, "%s: fmi2SetReal of %u after initialization returned %s\n", fmu->name, late[p].vr,
                STATUS[status <= fmi2Pending ? status : fmi2Fatal]);
        ok = status != fmi2Fatal && status != fmi2Pending;
    }
    FILE *out = ok ? fopen(argv[2], "w") : NULL;
    if (ok && !out) {
        fprintf(stderr, "cannot write %s\n", argv[2]);
        ok = 0;
    }
    if (out) {
        fprintf(out, "time");
        for (int o = 0; o < n_outputs; ++o) fprintf(out, ",%s", outputs[o].label);
        fprintf(out, "\n");
    }
    long steps = (long)(stop / step + 0.5);
    long long *cpu_ns = NULL, *wall_ns = NULL;
    if (ok && timed_fmu >= 0) {
        cpu_ns = calloc(steps > 0 ? steps : 1, sizeof *cpu_ns);
        wall_ns = calloc(steps > 0 ? steps : 1, sizeof *wall_ns);
        if (!cpu_ns || !wall_ns) ok = 0;
    }
    double carried[MAX], values[MAX];
    long timed = 0;
    for (long k = 0; ok && k < steps; ++k) {
        double time = k * step;
        for (int i = 0; ok && i < n_fmus; ++i) {
            for (int c = 0; ok && c < n_connections; ++c) {
                if (connections[c].dst != i) continue;
                Fmu *src = &fmus[connections[c].src];
                ok = check(src->get_real(src->instance, &connections[c].src_vr, 1, &carried[c]), src,
                           "fmi2GetReal", time);
            }
            long long cpu0 = nanoseconds(CLOCK_THREAD_CPUTIME_ID), wall0 = nanoseconds(CLOCK_MONOTONIC);
            for (int c = 0; ok && c < n_connections; ++c) {
                if (connections[c].dst != i) continue;
                ok = check(fmus[i].set_real(fmus[i].instance, &connections[c].dst_vr, 1, &carried[c]), &fmus[i],
                           "fmi2SetReal", time);
            }
            ok = ok && check(fmus[i].do_step(fmus[i].instance, time, step, 1), &fmus[i], "fmi2DoStep", time);
            for (int o = 0; ok && o < n_outputs; ++o) {
                if (outputs[o].fmu != i) continue;
                if (outputs[o].kind == 'b') {
                    int flag;
                    ok = check(fmus[i].get_boolean(fmus[i].instance, &outputs[o].vr, 1, &flag), &fmus[i],
                               "fmi2GetBoolean", time);
                    values[o] = flag;
                } else {
                    ok = check(fmus[i].get_real(fmus[i].instance, &outputs[o].vr, 1, &values[o]), &fmus[i],
                               "fmi2GetReal", time);
                }
            }
            if (ok && i == timed_fmu) {
                cpu_ns[k] = nanoseconds(CLOCK_THREAD_CPUTIME_ID) - cpu0;
                wall_ns[k] = nanoseconds(CLOCK_MONOTONIC) - wall0;
                timed = k + 1;
            }
        }
        if (!ok) break;
        fprintf(out, "%.17g", (k + 1) * step);
        for (int o = 0; o < n_outputs; ++o) fprintf(out, ",%.17g", values[o]);
        fprintf(out, "\n");
    }
    if (cpu_ns) {
        FILE *file = fopen(timing_path, "w");
        if (file) {
            fprintf(file, "step,cpu_ns,wall_ns\n");
            for (long k = 0; k < timed; ++k) fprintf(file, "%ld,%lld,%lld\n", k, cpu_ns[k], wall_ns[k]);
            fclose(file);
        } else {
            fprintf(stderr, "cannot write %s\n", timing_path);
            ok = 0;
        }
        free(cpu_ns);
        free(wall_ns);
    }
    for (int i = 0; ok && i < n_fmus; ++i) ok = check(fmus[i].terminate(fmus[i].instance), &fmus[i], "fmi2Terminate", stop);
    if (out) fclose(out);
    int unloaded = teardown();
    if (!ok) return 5;
    fprintf(stderr, "ran %ld steps of %g s\n", steps, step);
    return unloaded == n_fmus ? 0 : 5;
}
