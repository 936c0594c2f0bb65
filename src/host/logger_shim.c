/*
 * Variadic logger shim for the geardyn FMI 2.0 host.
 *
 * fmi2CallbackLogger is printf-style and variadic (FMI 2.0.5 §2.1.5, fmi2FunctionTypes.h).
 * Stable Rust can call C-variadic functions but cannot define one (c_variadic is unstable),
 * so the host passes `geardyn_host_logger` as `functions->logger`. It formats the message
 * with vsnprintf and forwards the text to a Rust callback.
 *
 * Routing is by componentEnvironment, never by a global: the FMU passes back the
 * componentEnvironment it received in fmi2Instantiate, which points to a
 * `geardyn_log_env` owned by the Rust instance (first field = Rust callback, second = its
 * context). Many instances per process therefore log to their own sinks.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*geardyn_log_forward_fn)(void *ctx, const char *instance_name, int status,
                                       const char *category, const char *message);

typedef struct {
    geardyn_log_forward_fn forward;
    void *ctx;
} geardyn_log_env;

void geardyn_host_logger(void *env, const char *instance_name, int status,
                         const char *category, const char *fmt, ...)
{
    char small[1024];
    char *text = small;
    char *heap = NULL;
    va_list ap, ap2;

    if (fmt == NULL) {
        fmt = "";
    }
    va_start(ap, fmt);
    va_copy(ap2, ap);
    /* First pass into a stack buffer; most messages fit. */
    int n = vsnprintf(small, sizeof small, fmt, ap);
    if (n < 0) {
        text = (char *)"(message could not be formatted)";
    } else if ((size_t)n >= sizeof small) {
        /* Second pass with the exact size (vsnprintf returns the length it needs). */
        heap = (char *)malloc((size_t)n + 1);
        if (heap != NULL) {
            vsnprintf(heap, (size_t)n + 1, fmt, ap2);
            text = heap;
        } /* else: keep the truncated stack text */
    }
    va_end(ap2);
    va_end(ap);

    geardyn_log_env *e = (geardyn_log_env *)env;
    if (e != NULL && e->forward != NULL) {
        e->forward(e->ctx, instance_name, status, category, text);
    } else {
        /* An FMU that lost its componentEnvironment: still show the message. */
        fprintf(stderr, "[%s] %s: %s\n", category ? category : "-",
                instance_name ? instance_name : "?", text);
    }
    free(heap);
}
