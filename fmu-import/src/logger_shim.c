/* The FMI 2.0 logger is a C variadic function: the message is a printf format. Stable Rust cannot
 * define a variadic function, so the importer's logger is this shim. It formats the message with
 * vsnprintf and hands the finished text to a non-variadic sink written in Rust. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*fmu_runtime_log_sink)(void *user, const char *instance, int status, const char *category,
                                     const char *message);

/* The componentEnvironment the importer passes to fmi2Instantiate. */
struct fmu_runtime_log_environment {
    fmu_runtime_log_sink sink;
    void *user;
};

void fmu_runtime_logger(void *environment, const char *instance, int status, const char *category,
                        const char *format, ...) {
    struct fmu_runtime_log_environment *env = (struct fmu_runtime_log_environment *)environment;
    if (env == NULL || env->sink == NULL) {
        return;
    }
    if (format == NULL) {
        env->sink(env->user, instance, status, category, "(NULL message)");
        return;
    }
    char stack_buffer[1024];
    char *buffer = stack_buffer;
    va_list args;
    va_start(args, format);
    va_list copy;
    va_copy(copy, args);
    int needed = vsnprintf(stack_buffer, sizeof stack_buffer, format, copy);
    va_end(copy);
    if (needed < 0) {
        /* Not a valid format: pass the raw text rather than nothing. */
        va_end(args);
        env->sink(env->user, instance, status, category, format);
        return;
    }
    if ((size_t)needed >= sizeof stack_buffer) {
        buffer = (char *)malloc((size_t)needed + 1);
        if (buffer == NULL) {
            va_end(args);
            env->sink(env->user, instance, status, category, stack_buffer);
            return;
        }
        vsnprintf(buffer, (size_t)needed + 1, format, args);
    }
    va_end(args);
    env->sink(env->user, instance, status, category, buffer);
    if (buffer != stack_buffer) {
        free(buffer);
    }
}
