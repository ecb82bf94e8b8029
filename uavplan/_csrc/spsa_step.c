/* uavplan._ckernels: one fused SPSA / SSA iteration (uavplan/planners/sparrow.py) with its
 * fitness cache, and the process-wide pool of helper threads it shares its work with. */
#include "kernels.h"

/* A cache of recent fitness values (recalled, not recomputed, when a candidate path was seen
 * before): ``slots`` (a power of two) entries, each a path stored as int32 grid values and its
 * energy; a path's slot is picked by a hash of its values, and a hit is a stored path equal
 * to it value for value (nothing else is trusted). Paths with a value that is not an int32
 * (or is −0.0) are not cached. The values are energy_one's: a hit returns exactly what a
 * recomputation would. */
typedef struct {
    unsigned char *filled; /* (slots,) */
    double *vals;          /* (slots,) */
    int32_t *paths;        /* (slots, m) */
    int64_t slots, m;
    int64_t part, nparts;  /* this user's share: the slots s with s mod nparts = part */
} ECache;

/* energy_bound's margin: far above the bound's and the energy's rounding (relative 1e-13) */
#define BOUND_MARGIN 1e-9

/* The path's slot in the cache, or -1 when there is no cache or the path is not cacheable. */
static int64_t cache_slot(const double *path, const ECache *c) {
    if (c == NULL || c->slots == 0) return -1;
    uint64_t h = 0x9E3779B97F4A7C15ULL;
    for (int64_t i = 0; i < c->m; i++) {
        double v = path[i];
        /* an int32 value (in range, the truncation is exact: equal iff v is an integer) */
        if (!(v >= -2147483648.0 && v <= 2147483647.0) || (double)(int32_t)v != v ||
            (v == 0.0 && signbit(v)))
            return -1;
        h = (h ^ (uint64_t)(uint32_t)(int32_t)v) * 0x100000001B3ULL;
    }
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 32;
    int64_t slot = (int64_t)(h & (uint64_t)(c->slots - 1));
    if (c->nparts > 1 && slot % c->nparts != c->part) return -1; /* another thread's share */
    return slot;
}

/* The path's energy: energy_one's value, recalled when the cache holds the path. With a
 * finite ``cutoff`` (greedy selection, which only asks whether a candidate beats its parent's
 * fitness), a path that is not cached and whose energy_bound proves its energy >= cutoff
 * gets ``cutoff`` itself, without the energy being computed. */
static double energy_cached(const double *path, const Energy *e, ECache *c, double cutoff) {
    int64_t slot = cache_slot(path, c);
    int32_t *stored = slot >= 0 ? c->paths + slot * c->m : NULL;
    if (slot >= 0 && c->filled[slot]) {
        int64_t i = 0;
        while (i < c->m && stored[i] == (int32_t)path[i]) i++;
        if (i == c->m) return c->vals[slot];
    }
    energy_knots(path, e);
    if (cutoff < INFINITY && bound_valid(e) &&
        bound_from_knots(e) * (1.0 - BOUND_MARGIN) >= cutoff)
        return cutoff;
    double energy = energy_from_knots(e); /* the knots are computed once for both */
    if (slot >= 0) {
        for (int64_t i = 0; i < c->m; i++) stored[i] = (int32_t)path[i];
        c->vals[slot] = energy;
        c->filled[slot] = 1;
    }
    return energy;
}

static int same_path(const double *a, const double *b, int64_t m) {
    for (int64_t i = 0; i < m; i++)
        if (a[i] != b[i]) return 0;
    return 1;
}

/* The fused step on up to STEP_MAX_THREADS threads. Every phase that works per individual
 * (the two rebuilds, the oscillation, the fitness) hands the individuals out one at a time;
 * ranking, the producers' best and the selection run on thread 0 between barriers. An
 * individual's work reads only its own random stream and the shared inputs of its phase, so
 * every result is the same, bit for bit, on any number of threads. What threads share: the
 * reachability memo (entries are single int64 stores, read and written with relaxed atomics;
 * a lost race only means an exact test is run again, so the count of exact tests, and only
 * that, can vary between runs with threads) and the fitness cache (thread t uses only its
 * share of the slots: slot mod nth = t). */

#if HAVE_THREADS
static uint64_t now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * 1000000000ull + (uint64_t)t.tv_nsec;
}

/* A waiting thread spins this long before it sleeps: most waits at a barrier are a few
 * microseconds (the phases are tens to hundreds), but a thread whose CPU was taken away (a
 * loaded machine, a virtual machine's neighbours) can keep the others waiting far longer,
 * and a spinning CPU is then only wasted. */
#define BARRIER_SPIN_NS 50000

/* A counter threads wait on to change (a barrier's or the pool's generation), with what a
 * waiter that stopped spinning sleeps on. */
typedef struct {
    uint64_t gen;
    int sleepers; /* under mu */
    pthread_mutex_t mu;
    pthread_cond_t cv;
} Signal;

/* Waits until sig->gen differs from ``seen`` (spinning for spin_ns, then sleeping); the new
 * value. */
static uint64_t signal_wait(Signal *sig, uint64_t seen, uint64_t spin_ns) {
    uint64_t g, t0 = now_ns();
    unsigned spins = 0;
    while ((g = __atomic_load_n(&sig->gen, __ATOMIC_ACQUIRE)) == seen) {
        if (++spins % 64 != 0) continue;
        sched_yield();
        if (now_ns() - t0 <= spin_ns) continue;
        pthread_mutex_lock(&sig->mu);
        sig->sleepers++;
        while ((g = __atomic_load_n(&sig->gen, __ATOMIC_ACQUIRE)) == seen)
            pthread_cond_wait(&sig->cv, &sig->mu);
        sig->sleepers--;
        pthread_mutex_unlock(&sig->mu);
        break;
    }
    return g;
}

/* Bumps sig->gen and wakes its sleepers (a sleeper counted itself and read gen under the
 * lock: it sees the new value, or it is waiting and this wakes it). */
static void signal_bump(Signal *sig) {
    __atomic_add_fetch(&sig->gen, 1, __ATOMIC_ACQ_REL);
    pthread_mutex_lock(&sig->mu);
    if (sig->sleepers > 0) pthread_cond_broadcast(&sig->cv);
    pthread_mutex_unlock(&sig->mu);
}
#endif

typedef struct {
    int n, count;
#if HAVE_THREADS
    Signal done; /* bumped each time the last of the n arrives */
#endif
} Barrier;

/* A generation barrier: the last of n threads to arrive bumps the generation the others
 * wait on */
static void barrier_wait(Barrier *b) {
#if HAVE_THREADS
    if (b->n <= 1) return;
    uint64_t seen = __atomic_load_n(&b->done.gen, __ATOMIC_ACQUIRE); /* before arriving */
    if (__atomic_add_fetch(&b->count, 1, __ATOMIC_ACQ_REL) == b->n) {
        __atomic_store_n(&b->count, 0, __ATOMIC_RELAXED);
        signal_bump(&b->done);
    } else {
        signal_wait(&b->done, seen, BARRIER_SPIN_NS);
    }
#else
    (void)b;
#endif
}

struct Step;

/* The next unclaimed index of a parallel phase: threads take individuals one at a time, so
 * a thread that drew cheap individuals takes more of them (an individual's cost varies
 * severalfold: failed proposals, escapes, exact tests). */
static inline int64_t take_next(int64_t *next) {
#if HAVE_THREADS
    return __atomic_fetch_add(next, 1, __ATOMIC_RELAXED);
#else
    return (*next)++;
#endif
}

typedef struct {
    struct Step *s;
    int tid;
    Energy e;      /* this thread's energy scratch */
    ECache cache;  /* this thread's share of the fitness cache */
    ECache *cp;    /* &cache, or NULL without a cache */
    double *new_;  /* oscillation scratch (m) */
    int64_t n_chk, n_exact, evals, esc;
} StepLocal;

typedef struct Step {
    double *x, *f;
    unsigned char *fixed;
    const double *line, *goal_u, *pdraw, *signs;
    const int64_t *aware;
    const uint64_t *seeds1, *seeds2;
    int64_t G, n, m, n_prod, n_aw, iters, t_max, v_min, v_max, window, flags;
    double warn, st_value;
    const Reach *r;
    double *cand, *cand_s, *anchor, *spread, *first, *p_best, *f_prod, *fc;
    int64_t *order, *moved, *draw, *scr_idx, *near_row;
    unsigned char *active, *use_first, *escape, *ok_p, *ok_s, *fresh, *changed, *skip, *aware_of;
    int64_t best_i, worst_i, failed;
    int64_t next[2]; /* the parallel phases' next individual (or producer rank) to take */
    int nth;
    Barrier bar;
    StepLocal loc[STEP_MAX_THREADS];
} Step;

/* thread 0: ranking, then the producers' proposals (eq. 11 or SSA's eq. 3; the alarm case
 * P + Q·L) */
static void step_rank_and_propose(Step *s) {
    int64_t G = s->G, m = s->m, n_prod = s->n_prod, flags = s->flags;
    const double *x = s->x, *f = s->f, *line = s->line, *pdraw = s->pdraw;
    int64_t *order = s->order;
    /* order: a stable argsort of f (insertion sort; G is a population) */
    for (int64_t i = 0; i < G; i++) {
        int64_t k = i;
        while (k > 0 && f[order[k - 1]] > f[i]) {
            order[k] = order[k - 1];
            k--;
        }
        order[k] = i;
    }
    s->best_i = order[0];
    s->worst_i = order[G - 1];
    /* (the rebuild reads the proposal rows of active individuals only: those are set whole) */
    for (int64_t g = 0; g < G; g++) {
        s->draw[g] = DRAW_NONE;
        s->active[g] = 0;
        s->use_first[g] = 0;
        s->escape[g] = 0;
    }
    if (s->warn < s->st_value) {
        for (int64_t i = 0; i < n_prod; i++) {
            int64_t g = order[i];
            /* e = exp(−i/(α·M)), i the producer's rank, α = pdraw[i] */
            double ex = exp((double)(-(i + 1)) / (pdraw[i] * (double)s->iters));
            double *an = s->anchor + g * m, *sp = s->spread + g * m;
            const double *p = x + g * m;
            s->active[g] = 1;
            for (int64_t k = 0; k < m; k++) {
                double l = line[k];
                if (!(flags & SPSA_START_END)) {
                    an[k] = l + (p[k] - l) * ex; /* eq. 3 about the line, no random term */
                    sp[k] = 0.0;
                } else if (flags & SPSA_LITERAL) {
                    an[k] = p[k] + ex;
                    sp[k] = l - p[k];
                } else {
                    double d = p[k] - l;
                    an[k] = l + d * ex;
                    sp[k] = -d;
                }
            }
            if (flags & SPSA_START_END) s->draw[g] = DRAW_UNIFORM;
        }
        if (flags & SPSA_START_END) {
            /* the best producer: P + rand·(P_ST − P) */
            double *an = s->anchor + s->best_i * m, *sp = s->spread + s->best_i * m;
            const double *p = x + s->best_i * m;
            for (int64_t k = 0; k < m; k++) {
                an[k] = p[k];
                sp[k] = line[k] - p[k];
            }
        }
    } else {
        for (int64_t i = 0; i < n_prod; i++) {
            int64_t g = order[i];
            double *an = s->anchor + g * m, *sp = s->spread + g * m, *fi = s->first + g * m;
            const double *p = x + g * m;
            s->active[g] = 1;
            s->draw[g] = DRAW_NORMAL;
            s->use_first[g] = 1;
            for (int64_t k = 0; k < m; k++) {
                an[k] = p[k];
                sp[k] = 1.0;
                fi[k] = p[k] + pdraw[i];
            }
        }
    }
    /* everyone else cannot fail the first rebuild; their rows of cand are all written in
     * step_rest (every individual that is not a producer is a scrounger) */
    for (int64_t g = 0; g < G; g++) s->ok_p[g] = 1;
}

/* every thread: producers' rebuild and fitness, one producer at a time */
static void step_producers(Step *s, StepLocal *L) {
    int64_t m = s->m, i;
    while ((i = take_next(&s->next[0])) < s->n_prod) {
        int64_t g = s->order[i];
        rebuild_core(s->x, s->G, s->n, s->active, s->anchor, NULL, s->spread, s->draw, NULL,
                     NULL, (double[2]){INFINITY, INFINITY}, s->first, s->use_first, NULL, NULL,
                     s->escape, s->t_max, s->v_min, s->v_max, s->r, s->seeds1, s->cand, s->ok_p,
                     &L->n_chk, &L->n_exact, g, g + 1);
        s->fresh[g] = 1;
        if (same_path(s->cand + g * m, s->x + g * m, m)) {
            s->f_prod[g] = s->f[g];
        } else {
            s->f_prod[g] = energy_cached(s->cand + g * m, &L->e, L->cp, INFINITY);
            L->evals++;
        }
    }
}

/* thread 0: the producers' best; which individuals are scroungers (their eq. 4 index) and
 * danger-aware sparrows (their proposals are made by the threads, in step_propose_rest) */
static void step_roles(Step *s) {
    int64_t G = s->G, m = s->m, n_prod = s->n_prod, flags = s->flags;
    int64_t n_scr = G - n_prod;
    int64_t pb = -1;
    for (int64_t i = 0; i < n_prod; i++) {
        int64_t g = s->order[i];
        if (pb < 0 || s->f_prod[g] < s->f_prod[pb]) pb = g;
    }
    memcpy(s->p_best, s->cand + pb * m, sizeof(double) * m);
    for (int64_t i = n_prod; i < G; i++) s->fresh[s->order[i]] = 0;
    for (int64_t g = 0; g < G; g++) {
        s->scr_idx[g] = -1;
        s->near_row[g] = -1;
        s->aware_of[g] = 0;
    }
    int64_t i0 = (flags & SPSA_POP_INDEX) ? n_prod + 1 : 1;
    double half = (flags & SPSA_POP_INDEX) ? (double)G / 2.0 : (double)n_scr / 2.0;
    int64_t near_k = 0;
    for (int64_t k0 = 0; k0 < n_scr; k0++) {
        int64_t g = s->order[n_prod + k0];
        s->scr_idx[g] = i0 + k0;
        if (!((double)(i0 + k0) > half)) s->near_row[g] = near_k++;
    }
    for (int64_t i = 0; i < s->n_aw; i++) s->aware_of[s->aware[i]] = 1;
}

/* individual g's second proposal: a scrounger's (eq. 4, eq. 12's escape), then, for a
 * danger-aware sparrow, eq. 5's in its place; sets active, escape and draw for g */
static void step_propose_rest(Step *s, int64_t g) {
    int64_t G = s->G, n = s->n, m = s->m, flags = s->flags;
    int64_t n_scr = G - s->n_prod;
    const double *x = s->x, *f = s->f, *line = s->line;
    double *an = s->anchor + g * m, *sp = s->spread + g * m;
    const double *p = x + g * m;
    s->draw[g] = DRAW_NONE;
    s->active[g] = 0;
    s->escape[g] = 0;
    if (s->scr_idx[g] >= 0) {
        int64_t idx = s->scr_idx[g];
        double half = (flags & SPSA_POP_INDEX) ? (double)G / 2.0 : (double)n_scr / 2.0;
        s->active[g] = 1;
        s->escape[g] = (flags & SPSA_ESCAPE) ? 1 : 0;
        if ((double)idx > half) {
            /* i > n/2: Q·exp((P_worst − P)/i²) about the line */
            const double *xw = x + s->worst_i * m;
            double i2 = (double)idx * (double)idx;
            for (int64_t k = 0; k < m; k++) {
                double v = ((xw[k] - line[k]) - (p[k] - line[k])) / i2;
                an[k] = line[k];
                sp[k] = exp(v > 50.0 ? 50.0 : v);
            }
            s->draw[g] = DRAW_NORMAL;
        } else {
            /* P_p + |P − P_p|·A⁺·L: one offset per path */
            const double *sg = s->signs + s->near_row[g] * m;
            const double *pbest = s->p_best;
            double sy = 0.0, sz = 0.0;
            for (int64_t j = 0; j < n; j++) {
                sy += fabs(p[2 * j] - pbest[2 * j]) * sg[2 * j];
                sz += fabs(p[2 * j + 1] - pbest[2 * j + 1]) * sg[2 * j + 1];
            }
            sy = sy / (double)n;
            sz = sz / (double)n;
            for (int64_t j = 0; j < n; j++) {
                an[2 * j] = pbest[2 * j] + sy;
                an[2 * j + 1] = pbest[2 * j + 1] + sz;
                sp[2 * j] = 0.0;
                sp[2 * j + 1] = 0.0;
            }
        }
    }
    if (s->aware_of[g]) {
        s->active[g] = 1;
        s->escape[g] = 0;
        if (!(f[g] <= f[s->best_i])) {
            /* not the best: P_best + β·|P − P_best| */
            const double *xb = x + s->best_i * m;
            for (int64_t k = 0; k < m; k++) {
                an[k] = xb[k];
                sp[k] = fabs(p[k] - xb[k]);
            }
            s->draw[g] = DRAW_NORMAL;
        } else {
            /* the best: P + K·|P − P_worst|/(f_i − f_w + ε) */
            const double *xw = x + s->worst_i * m;
            double kk = 1.0 / (f[g] - f[s->worst_i] + SPSA_EPS);
            for (int64_t k = 0; k < m; k++) {
                an[k] = p[k];
                sp[k] = fabs(p[k] - xw[k]) * kk;
            }
            s->draw[g] = DRAW_SYMMETRIC;
        }
    }
}

/* every thread: its scroungers' and danger-aware sparrows' rebuild, the oscillation
 * optimisation (eq. 13) and the candidates' fitness */
static void step_rest(Step *s, StepLocal *L) {
    int64_t G = s->G, m = s->m, g;
    while ((g = take_next(&s->next[1])) < G) {
        step_propose_rest(s, g);
        /* (an inactive individual's row: copied from x, unchanged) */
        L->esc += rebuild_core(s->x, G, s->n, s->active, s->anchor, NULL, s->spread, s->draw,
                               NULL, NULL, (double[2]){INFINITY, INFINITY}, NULL, NULL, NULL,
                               NULL, s->escape, s->t_max, s->v_min, s->v_max, s->r, s->seeds2,
                               s->cand_s, s->ok_s, &L->n_chk, &L->n_exact, g, g + 1);
        if (s->active[g]) {
            memcpy(s->cand + g * m, s->cand_s + g * m, sizeof(double) * m);
            s->fresh[g] = 0;
        }
        s->changed[g] = !same_path(s->cand + g * m, s->x + g * m, m);
        if (s->flags & SPSA_OSCILLATE) {
            s->moved[g] = 0;
            s->skip[g] = !s->changed[g] && s->fixed[g]; /* a known fixed point of eq. 13 */
            mar_core(s->cand, G, s->n, s->goal_u, s->window, s->r, s->skip, s->moved, L->new_,
                     &L->n_chk, &L->n_exact, g, g + 1);
            if (!s->changed[g] && !s->skip[g]) s->fixed[g] = s->moved[g] == 0;
            if (s->moved[g] > 0) {
                s->fresh[g] = 0;
                s->changed[g] = !same_path(s->cand + g * m, s->x + g * m, m);
            }
        }
        if (!s->changed[g]) continue;
        if (s->fresh[g]) {
            s->fc[g] = s->f_prod[g]; /* a producer's candidate evaluated above, not moved since */
        } else {
            s->fc[g] = energy_cached(s->cand + g * m, &L->e, L->cp, s->f[g]);
            L->evals++;
        }
    }
}

/* thread 0: greedy selection */
static void step_select(Step *s) {
    int64_t m = s->m;
    int64_t failed = 0;
    for (int64_t g = 0; g < s->G; g++) {
        failed += !s->ok_p[g] + !s->ok_s[g];
        if (!s->changed[g]) continue;
        if (s->fc[g] < s->f[g]) {
            memcpy(s->x + g * m, s->cand + g * m, sizeof(double) * m);
            s->f[g] = s->fc[g];
            if (s->flags & SPSA_OSCILLATE) s->fixed[g] = 0;
        }
    }
    s->failed = failed;
}

static void step_run(StepLocal *L) {
    Step *s = L->s;
    if (L->tid == 0) step_rank_and_propose(s);
    barrier_wait(&s->bar);
    step_producers(s, L);
    barrier_wait(&s->bar);
    if (L->tid == 0) step_roles(s);
    barrier_wait(&s->bar);
    step_rest(s, L);
    barrier_wait(&s->bar);
    if (L->tid == 0) step_select(s);
}

#if HAVE_THREADS
/* The step's helper threads live in a process-wide pool, started on first use and parked
 * between steps: starting a thread costs 50-70 microseconds here, a tenth of a step. A
 * helper waits for the next step spinning for 0.2 ms (the Python code between two steps
 * takes about 0.1 ms), then sleeps on a condition variable. One step uses the
 * pool at a time: a step that finds it busy (another Python thread is planning) runs on its
 * caller's thread alone, with the same results. After fork() the child has no helpers: the
 * pool starts again. */
#define POOL_SPIN_NS 200000

typedef struct {
    Signal step;  /* its generation is bumped for each step */
    int started;  /* helpers running (tids 1 .. started) */
    int busy;     /* a step holds the pool */
    Step *job;    /* the current step */
    int finished; /* helpers done with the current step */
    int atfork;   /* the fork handler is registered */
} Pool;

static Pool pool = {{0, 0, PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER}, 0, 0, NULL, 0, 0};
/* the generation each helper was started at: it waits for the one after (a helper that read
 * pool.gen itself might read it after the step that started it had bumped it, and wait for
 * a step that never comes) */
static uint64_t pool_start_gen[STEP_MAX_THREADS];

static void pool_atfork_child(void) {
    pthread_mutex_init(&pool.step.mu, NULL);
    pthread_cond_init(&pool.step.cv, NULL);
    pool.step.sleepers = 0;
    pool.started = 0;
    pool.busy = 0;
    pool.job = NULL;
    pool.finished = 0;
}

static void *pool_helper(void *arg) {
    int tid = (int)(intptr_t)arg;
    uint64_t seen = pool_start_gen[tid];
    for (;;) {
        seen = signal_wait(&pool.step, seen, POOL_SPIN_NS);
        Step *s = __atomic_load_n(&pool.job, __ATOMIC_ACQUIRE);
        if (s != NULL && tid < s->nth) step_run(&s->loc[tid]);
        __atomic_add_fetch(&pool.finished, 1, __ATOMIC_ACQ_REL);
    }
    return NULL;
}

/* Holds the pool for one step with at least want − 1 helpers running; the helpers available
 * (0 when the pool is busy or no thread could be started). */
static int pool_acquire(int want) {
    int expected = 0;
    if (!__atomic_compare_exchange_n(&pool.busy, &expected, 1, 0, __ATOMIC_ACQUIRE,
                                     __ATOMIC_RELAXED))
        return 0;
    if (!pool.atfork) {
        pthread_atfork(NULL, NULL, pool_atfork_child);
        pool.atfork = 1;
    }
    while (pool.started < want - 1 && pool.started < STEP_MAX_THREADS - 1) {
        pthread_t th;
        pthread_attr_t attr;
        pthread_attr_init(&attr);
        pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
        pool_start_gen[pool.started + 1] = __atomic_load_n(&pool.step.gen, __ATOMIC_ACQUIRE);
        int rc = pthread_create(&th, &attr, pool_helper, (void *)(intptr_t)(pool.started + 1));
        pthread_attr_destroy(&attr);
        if (rc != 0) break;
        pool.started++;
    }
    return pool.started;
}
#endif

/* Runs the step on s->nth threads: the caller's and nth − 1 of the pool's helpers (fewer if
 * the pool is busy or the system refuses a thread: the results are the same). Helpers beyond
 * nth − 1 wake, find nothing to do and count themselves finished. */
static void step_parallel(Step *s) {
#if HAVE_THREADS
    if (s->nth > 1) {
        int helpers = pool_acquire(s->nth);
        if (helpers > 0) {
            if (s->nth > helpers + 1) s->nth = helpers + 1;
            s->bar.n = s->nth;
            pthread_mutex_init(&s->bar.done.mu, NULL);
            pthread_cond_init(&s->bar.done.cv, NULL);
            __atomic_store_n(&pool.finished, 0, __ATOMIC_RELAXED);
            __atomic_store_n(&pool.job, s, __ATOMIC_RELEASE);
            signal_bump(&pool.step);
            step_run(&s->loc[0]);
            unsigned spins = 0;
            while (__atomic_load_n(&pool.finished, __ATOMIC_ACQUIRE) < helpers)
                if (++spins % 64 == 0) sched_yield();
            __atomic_store_n(&pool.job, NULL, __ATOMIC_RELEASE);
            __atomic_store_n(&pool.busy, 0, __ATOMIC_RELEASE);
            pthread_cond_destroy(&s->bar.done.cv);
            pthread_mutex_destroy(&s->bar.done.mu);
            return;
        }
    }
#endif
    s->nth = 1;
    s->bar.n = 1;
    step_run(&s->loc[0]);
}

/* spsa_step(x, f, osc_fixed, counts, setup, draws)
 *
 * One iteration of SparrowPlanner.step, in place on x (G, n, 2), f (G,) and osc_fixed (G,):
 * producers (eq. 11 or eq. 3), their rebuild under the reachability rule and fitness, then
 * scroungers (eq. 4 with eq. 12's escape) and danger-aware sparrows (eq. 5), their rebuild,
 * the oscillation optimisation (eq. 13) and greedy selection. ``setup`` (a StepSetup) is what
 * every step of a search shares: the reachability rule, the energy, the start-end line, the
 * parameters, the fitness cache and the threads. ``draws`` (a StepDraws) are the random
 * numbers numpy's Generator draws for the step (``warn``: R2; ``pdraw`` (n_prod,): α = 1 − U
 * when R2 < ST else Q ~ N(0, 1); ``signs`` (near, n, 2): eq. 4's ±1; ``aware``: the
 * danger-aware sparrows; ``seeds1`` / ``seeds2`` (G,): the two rebuilds' streams), so the
 * step is the same function of the Generator as the numpy formulation
 * (uavplan/planners/sparrow_numpy.py). ``counts`` (3,) int64 gets += (evaluations, escapes,
 * failed updates). */
PyObject *py_spsa_step(PyObject *self, PyObject *args) {
    PyObject *ox, *of, *ofix, *ocnt, *osetup, *odraws;
    Buf bx = {0}, bf = {0}, bfix = {0}, bcnt = {0};
    StepArgs a;
    ECache cache = {0}, *cp = NULL;
    double *mem = NULL;
    int have_args = 0;
    if (!PyArg_ParseTuple(args, "OOOOOO", &ox, &of, &ofix, &ocnt, &osetup, &odraws))
        return NULL;
    PyObject *ret = NULL;
    if (get_buf(ox, &bx, T_F64, 3, 1, "x") < 0 || get_buf(of, &bf, T_F64, 1, 1, "f") < 0 ||
        get_buf(ofix, &bfix, T_BOOL, 1, 1, "osc_fixed") < 0 ||
        get_buf(ocnt, &bcnt, T_I64, 1, 1, "counts") < 0)
        goto done;
    int64_t G = dim(&bx, 0), n = dim(&bx, 1);
    int64_t m = 2 * n;
    if (step_args_get(osetup, odraws, n, &a) < 0) goto done;
    have_args = 1;
    const Reach *r = &a.r;
    long long n_prod = a.n_prod, flags = a.flags;
    int64_t n_scr = G - n_prod;
    int64_t n_aw = dim(a.aware, 0);
    if (need(dim(&bx, 2) == 2 && n >= 1 && n <= r->ncols - 2 && dim(&bf, 0) == G &&
                 dim(&bfix, 0) == G && dim(a.line, 0) == n && dim(a.line, 1) == 2 &&
                 dim(a.goal_u, 0) >= 2 && 1 <= n_prod && n_prod < G &&
                 dim(a.pdraw, 0) == n_prod && dim(a.seeds1, 0) == G && dim(a.seeds2, 0) == G &&
                 dim(&bcnt, 0) == 3 && n_aw <= G && a.iterations >= 1 && a.t_max >= 1 &&
                 a.window >= 3 && 1 <= a.v_min && a.v_min <= a.v_max &&
                 (dim(a.signs, 0) == 0 || (dim(a.signs, 1) == n && dim(a.signs, 2) == 2)),
             "spsa_step: inconsistent arguments") < 0)
        goto done;
    {
        const int64_t *aw = I64(*a.aware);
        for (int64_t i = 0; i < n_aw; i++)
            if (need(0 <= aw[i] && aw[i] < G, "spsa_step: aware index out of range") < 0)
                goto done;
    }
    {
        /* eq. 4's near scroungers (rank i <= n/2): one row of signs each */
        int64_t i0 = (flags & SPSA_POP_INDEX) ? n_prod + 1 : 1;
        double half = (flags & SPSA_POP_INDEX) ? (double)G / 2.0 : (double)n_scr / 2.0;
        int64_t near = 0;
        for (int64_t s = 0; s < n_scr; s++) near += (double)(i0 + s) <= half;
        if (need(near == dim(a.signs, 0), "spsa_step: signs: one row per near scrounger") < 0)
            goto done;
    }
    if (a.has_cache) {
        cache.slots = dim(a.filled, 0);
        cache.m = m;
        if (need(dim(a.values, 0) == cache.slots && dim(a.paths, 0) == cache.slots &&
                     dim(a.paths, 1) == m && (cache.slots & (cache.slots - 1)) == 0,
                 "spsa_step: cache: (slots,) flags and values, (slots, 2n) paths, slots a power "
                 "of two") < 0)
            goto done;
        cache.filled = BOOL(*a.filled);
        cache.vals = F64(*a.values);
        cache.paths = (int32_t *)a.paths->view.buf;
        cp = &cache;
    }
    /* scratch: cand, cand_s, anchor, spread, first (G·m each), p_best (m), new_ (m per
     * thread), f_prod, fc (G each); int64 order, moved, draw, scr_idx, near_row (G each); 9
     * byte flags (G each) */
    long long threads = a.threads;
    int nth = threads < 1 ? 1 : threads > STEP_MAX_THREADS ? STEP_MAX_THREADS : (int)threads;
    if (nth > G) nth = (int)G;
    if (!HAVE_THREADS) nth = 1;
    size_t nd = (size_t)(5 * G * m + m + (int64_t)nth * m + 2 * G);
    mem = malloc(sizeof(double) * nd + sizeof(int64_t) * 5 * (size_t)G + 9 * (size_t)G);
    if (mem == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Step st = {.x = F64(bx), .f = F64(bf), .fixed = BOOL(bfix), .line = F64(*a.line),
               .goal_u = F64(*a.goal_u), .pdraw = F64(*a.pdraw), .signs = F64(*a.signs),
               .aware = I64(*a.aware), .seeds1 = U64(*a.seeds1), .seeds2 = U64(*a.seeds2),
               .G = G, .n = n, .m = m, .n_prod = n_prod, .n_aw = n_aw, .iters = a.iterations,
               .t_max = a.t_max, .v_min = a.v_min, .v_max = a.v_max, .window = a.window,
               .flags = flags, .warn = a.warn, .st_value = a.warning_value,
               .r = r}; /* the rest zero */
    st.cand = mem;
    st.cand_s = st.cand + G * m;
    st.anchor = st.cand_s + G * m;
    st.spread = st.anchor + G * m;
    st.first = st.spread + G * m;
    st.p_best = st.first + G * m;
    double *news = st.p_best + m;
    st.f_prod = news + (int64_t)nth * m;
    st.fc = st.f_prod + G;
    st.order = (int64_t *)(st.fc + G);
    st.moved = st.order + G;
    st.draw = st.moved + G;
    st.scr_idx = st.draw + G;
    st.near_row = st.scr_idx + G;
    st.active = (unsigned char *)(st.near_row + G);
    st.use_first = st.active + G;
    st.escape = st.use_first + G;
    st.ok_p = st.escape + G;
    st.ok_s = st.ok_p + G;
    st.fresh = st.ok_s + G;
    st.changed = st.fresh + G;
    st.skip = st.changed + G;
    st.aware_of = st.skip + G;
    /* per thread: energy scratch, a share of the fitness cache, oscillation scratch */
    for (int t = 0; t < nth; t++) {
        StepLocal *L = &st.loc[t];
        L->s = &st;
        L->tid = t;
        L->new_ = news + (int64_t)t * m;
        L->e = a.e;
        if (t > 0) {
            L->e.work = NULL;
            if (energy_init(&L->e) < 0) {
                for (int u = 1; u < t; u++) free(st.loc[u].e.work);
                goto done;
            }
        }
        if (cp != NULL) {
            L->cache = cache;
            L->cache.part = t;
            L->cache.nparts = nth;
            L->cp = &L->cache;
        }
    }
    st.nth = nth;
    /* From here to the counts, plain C on the buffers acquired above: other Python threads
     * run meanwhile (the CLI imports the mission writer's libraries during the search). */
    PyThreadState *ts = PyEval_SaveThread();
    step_parallel(&st);
    int64_t n_chk = 0, n_exact = 0, evals = 0, esc = 0;
    for (int t = 0; t < nth; t++) {
        n_chk += st.loc[t].n_chk;
        n_exact += st.loc[t].n_exact;
        evals += st.loc[t].evals;
        esc += st.loc[t].esc;
        if (t > 0) free(st.loc[t].e.work);
    }
    r->counts[0] += n_chk;
    r->counts[1] += n_exact;
    int64_t *counts = I64(bcnt);
    counts[0] += evals;
    counts[1] += esc;
    counts[2] += st.failed;
    PyEval_RestoreThread(ts);
    ret = Py_NewRef(Py_None);
done:
    free(mem);
    if (have_args) step_args_release(&a);
    rel(&bx);
    rel(&bf);
    rel(&bfix);
    rel(&bcnt);
    return ret;
}

