/*
 * scene_eval.c - the scene model (validation, derived geometry, shading)
 * and its estimators: uniform hemisphere, BRDF and light sampling, and
 * multi-sample MIS, each wrapped as a qmc_integrand over [0,1)^(2 k).
 *
 * Must not: allocate, keep state between calls, or write to the job from
 * eval (several threads may evaluate one job at once).  A sample whose
 * density is 0 contributes 0 and is never divided by.
 *
 * Why every accepted (scene, strategy) is unbiased: the uniform and the
 * cosine densities are positive on the whole open upper hemisphere, where
 * the integrand lives; the Phong mixture has a cosine part of weight
 * kd / (kd + ks), and when kd = 0 its power-cosine lobe is positive
 * wherever cos(alpha) > 0, which is where f is; the light densities are
 * positive on exactly the directions that reach the light's emitting side.
 * MIS needs only the union of its techniques' supports.  Every estimator
 * is also bounded (f cos / p is bounded for each technique, and the
 * point keeps a positive distance from the light), so variances are finite.
 */
#include <math.h>
#include <string.h>

#include "scene_impl.h"

#define PI QMC__SCENE_PI

void qmc__scene_frame(qmc_vec3 z, qmc_vec3 *t1, qmc_vec3 *t2)
{
    double sign = copysign(1.0, z.z);
    double a = -1.0 / (sign + z.z);
    double b = z.x * z.y * a;
    *t1 = qmc__v3(1.0 + sign * z.x * z.x * a, sign * b, -sign * z.x);
    *t2 = qmc__v3(b, sign + z.y * z.y * a, -z.y);
}

/* ---- validation ----------------------------------------------------------- */

static int finite3(const double *v, double cap)
{
    for (int i = 0; i < 3; i++)
        if (!isfinite(v[i]) || fabs(v[i]) > cap)
            return 0;
    return 1;
}

const char *qmc__scene_field_problem(qmc__scene_field f, const double *v)
{
    switch (f) {
    case QMC__SF_POINT:
    case QMC__SF_CENTER:
    case QMC__SF_CORNER:
        return finite3(v, QMC_SCENE_MAX_COORD)
                   ? NULL
                   : "coordinates must be finite and at most 1e9 in magnitude";
    case QMC__SF_NORMAL:
    case QMC__SF_VIEW:
    case QMC__SF_EDGE1:
    case QMC__SF_EDGE2:
        if (!finite3(v, QMC_SCENE_MAX_COORD))
            return "components must be finite and at most 1e9 in magnitude";
        if (!(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > 0.0))
            return f == QMC__SF_NORMAL ? "zero-length normal"
                   : f == QMC__SF_VIEW ? "zero-length view direction"
                                       : "zero-length edge";
        return NULL;
    case QMC__SF_ALBEDO:
        return isfinite(v[0]) && v[0] > 0.0 && v[0] <= 1.0
                   ? NULL
                   : "albedo must be in (0, 1]";
    case QMC__SF_KD:
        return isfinite(v[0]) && v[0] >= 0.0 && v[0] <= 1.0
                   ? NULL
                   : "kd must be in [0, 1]";
    case QMC__SF_KS:
        return isfinite(v[0]) && v[0] >= 0.0 && v[0] <= 1.0
                   ? NULL
                   : "ks must be in [0, 1]";
    case QMC__SF_EXPONENT:
        return isfinite(v[0]) && v[0] >= 0.0 && v[0] <= QMC_SCENE_MAX_EXPONENT
                   ? NULL
                   : "exponent must be in [0, 1e4]";
    case QMC__SF_RADIUS:
        return isfinite(v[0]) && v[0] > 0.0 && v[0] <= QMC_SCENE_MAX_COORD
                   ? NULL
                   : "radius must be > 0 and at most 1e9";
    case QMC__SF_RADIANCE:
        return isfinite(v[0]) && v[0] > 0.0 ? NULL
                                            : "radiance must be finite and > 0";
    case QMC__SF_SIGMA_T:
        return isfinite(v[0]) && v[0] >= 0.0 ? NULL
                                             : "sigma_t must be finite and >= 0";
    default:
        return NULL;
    }
}

static int fail(qmc__msg *m, qmc__scene_field *field, qmc__scene_field f,
                const char *why)
{
    *field = f;
    if (m)
        qmc__msg_str(m, why);
    return QMC_EDOMAIN;
}

/* Runs one field check; nonzero (and the reason) when it fails. */
static int field_bad(qmc__msg *m, qmc__scene_field *field, qmc__scene_field f,
                     qmc_vec3 v)
{
    double a[3] = {v.x, v.y, v.z};
    const char *why = qmc__scene_field_problem(f, a);
    return why ? fail(m, field, f, why) : 0;
}

static int scalar_bad(qmc__msg *m, qmc__scene_field *field, qmc__scene_field f,
                      double x)
{
    return field_bad(m, field, f, qmc__v3(x, 0.0, 0.0));
}

static int validate_light(const qmc_scene *s, qmc__scene_field *field,
                          qmc__msg *m)
{
    qmc_vec3 n = qmc__scale(s->normal, 1.0 / qmc__len(s->normal));
    int rc;

    if ((rc = scalar_bad(m, field, QMC__SF_RADIANCE, s->radiance)))
        return rc;
    if (s->light == QMC_SCENE_SPHERE) {
        if ((rc = field_bad(m, field, QMC__SF_CENTER, s->center)) ||
            (rc = scalar_bad(m, field, QMC__SF_RADIUS, s->radius)))
            return rc;
        qmc_vec3 v = qmc__sub(s->center, s->point);
        double dist = qmc__len(v);
        if (!(dist > s->radius))
            return fail(m, field, QMC__SF_LIGHT,
                        "the shading point is inside or on the sphere light");
        if (s->radius / dist < QMC_SCENE_MIN_SIN_ANGLE)
            return fail(m, field, QMC__SF_LIGHT,
                        "the sphere light is too small or too far: "
                        "radius / distance < 1e-4");
        if (qmc__dot(v, n) <= -s->radius)
            return fail(m, field, QMC__SF_LIGHT,
                        "the sphere light is wholly below the horizon");
        return 0;
    }
    if (s->light != QMC_SCENE_RECT)
        return fail(m, field, QMC__SF_LIGHT, "unknown light kind");
    if ((rc = field_bad(m, field, QMC__SF_CORNER, s->corner)) ||
        (rc = field_bad(m, field, QMC__SF_EDGE1, s->edge1)) ||
        (rc = field_bad(m, field, QMC__SF_EDGE2, s->edge2)))
        return rc;
    qmc_vec3 mv = qmc__cross(s->edge1, s->edge2);
    double ml = qmc__len(mv);
    if (!(ml > 1e-9 * qmc__len(s->edge1) * qmc__len(s->edge2)))
        return fail(m, field, QMC__SF_LIGHT, "the rect's edges are parallel");
    double h = qmc__dot(qmc__sub(s->point, s->corner), mv) / ml;
    double scale = qmc__len(s->edge1) + qmc__len(s->edge2);
    if (fabs(h) <= 1e-9 * scale)
        return fail(m, field, QMC__SF_LIGHT,
                    "the shading point lies in the rect light's plane");
    if (h < 0.0)
        return fail(m, field, QMC__SF_LIGHT,
                    "the rect light emits away from the shading point (it "
                    "emits toward edge1 x edge2; swap edge1 and edge2)");
    double top = -INFINITY;
    for (int i = 0; i < 4; i++) {
        qmc_vec3 q = s->corner;
        if (i & 1)
            q = qmc__add(q, s->edge1);
        if (i & 2)
            q = qmc__add(q, s->edge2);
        top = fmax(top, qmc__dot(qmc__sub(q, s->point), n));
    }
    if (!(top > 0.0))
        return fail(m, field, QMC__SF_LIGHT,
                    "the rect light is wholly below the horizon");
    return 0;
}

int qmc__scene_validate(const qmc_scene *s, qmc__scene_field *field,
                        qmc__msg *m)
{
    int rc;

    *field = QMC__SF_NONE;
    if ((rc = field_bad(m, field, QMC__SF_POINT, s->point)) ||
        (rc = field_bad(m, field, QMC__SF_NORMAL, s->normal)) ||
        (rc = field_bad(m, field, QMC__SF_VIEW, s->view)))
        return rc;
    if (!(qmc__dot(s->view, s->normal) > 1e-9 * qmc__len(s->view) *
                                             qmc__len(s->normal)))
        return fail(m, field, QMC__SF_VIEW,
                    "the view direction must point above the surface "
                    "(view . normal > 0)");
    if (s->brdf == QMC_SCENE_LAMBERT) {
        if ((rc = scalar_bad(m, field, QMC__SF_ALBEDO, s->albedo)))
            return rc;
    } else if (s->brdf == QMC_SCENE_PHONG) {
        if ((rc = scalar_bad(m, field, QMC__SF_KD, s->kd)) ||
            (rc = scalar_bad(m, field, QMC__SF_KS, s->ks)) ||
            (rc = scalar_bad(m, field, QMC__SF_EXPONENT, s->exponent)))
            return rc;
        if (!(s->kd + s->ks > 0.0))
            return fail(m, field, QMC__SF_BRDF,
                        "phong needs kd + ks > 0 (it reflects nothing)");
        if (s->kd + s->ks > 1.0)
            return fail(m, field, QMC__SF_BRDF,
                        "phong needs kd + ks <= 1 (energy conservation)");
    } else {
        return fail(m, field, QMC__SF_BRDF, "unknown brdf kind");
    }
    if ((rc = validate_light(s, field, m)))
        return rc;
    return scalar_bad(m, field, QMC__SF_SIGMA_T, s->sigma_t);
}

int qmc_scene_check(const qmc_scene *s, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__scene_field field;

    qmc__msg_init(&m, why, why_bytes);
    if (s == NULL) {
        qmc__msg_str(&m, "no scene");
        return QMC_EINVAL;
    }
    return qmc__scene_validate(s, &field, &m);
}

/* ---- geometry and shading ---------------------------------------------------- */

void qmc__scene_geom_init(const qmc_scene *s, qmc__scene_geom *g)
{
    qmc_vec3 v;

    memset(g, 0, sizeof *g);
    g->p = s->point;
    g->n = qmc__scale(s->normal, 1.0 / qmc__len(s->normal));
    qmc__scene_frame(g->n, &g->n1, &g->n2);
    v = qmc__scale(s->view, 1.0 / qmc__len(s->view));
    g->r = qmc__sub(qmc__scale(g->n, 2.0 * qmc__dot(g->n, v)), v);
    g->r = qmc__scale(g->r, 1.0 / qmc__len(g->r));
    qmc__scene_frame(g->r, &g->r1, &g->r2);
    if (s->brdf == QMC_SCENE_PHONG) {
        g->phong = 1;
        g->diffuse = s->kd / PI;
        g->spec = s->ks * (s->exponent + 2.0) / (2.0 * PI);
        g->expo = s->exponent;
        g->p_diffuse = s->kd / (s->kd + s->ks);
    } else {
        g->diffuse = s->albedo / PI;
        g->p_diffuse = 1.0;
    }
    g->radiance = s->radiance;
    g->sigma_t = s->sigma_t;
    if (s->light == QMC_SCENE_SPHERE) {
        g->sphere = 1;
        v = qmc__sub(s->center, s->point);
        g->dist = qmc__len(v);
        g->radius = s->radius;
        g->a = qmc__scale(v, 1.0 / g->dist);
        qmc__scene_frame(g->a, &g->a1, &g->a2);
        /* cos = sqrt(D^2 - r^2) / D, factored to avoid cancellation. */
        g->cos_max = sqrt((g->dist - g->radius) * (g->dist + g->radius)) /
                     g->dist;
        /* The cone's solid angle is 2 pi (1 - cos); from cos_max that
         * difference keeps only eps / (1 - cos) of its digits - 2.5e-9 for
         * a light 3e-4 rad wide, a bias 1000x the light technique's bar.
         * 1 - cos = (r / D)^2 / (1 + cos) has no cancellation. */
        g->omc = g->radius / g->dist * (g->radius / g->dist) / (1.0 + g->cos_max);
    } else {
        g->c = s->corner;
        g->e1 = s->edge1;
        g->e2 = s->edge2;
        g->m = qmc__cross(g->e1, g->e2);
        g->area = qmc__len(g->m);
        g->nl = qmc__scale(g->m, 1.0 / g->area);
        g->inv_m2 = 1.0 / qmc__dot(g->m, g->m);
        g->height = qmc__dot(qmc__sub(g->p, g->c), g->nl);
        double den = qmc__dot(g->r, g->nl);
        g->peak_dist = den < 0.0 ? g->height / -den : 0.0;
    }
}

double qmc__scene_shade(const qmc__scene_geom *g, qmc_vec3 w, double dist)
{
    double cos_n = qmc__dot(w, g->n);
    double f = g->diffuse;

    if (!(cos_n > 0.0))
        return 0.0;
    if (g->phong) {
        double ca = qmc__dot(w, g->r);
        if (ca > 0.0)
            f += g->spec * pow(fmin(ca, 1.0), g->expo);
    }
    if (g->sigma_t > 0.0)
        f *= exp(-g->sigma_t * dist);
    return f * g->radiance * fmin(cos_n, 1.0);
}

double qmc__scene_sphere_dist(const qmc__scene_geom *g, double u)
{
    double disc = g->radius * g->radius -
                  g->dist * g->dist * ((1.0 - u) * (1.0 + u));
    return g->dist * u - sqrt(fmax(0.0, disc));
}

/* The light technique's density at a direction in the cone (or reaching
 * the rect at distance t with cosine cos_l). */
static double cone_pdf(const qmc__scene_geom *g)
{
    return 1.0 / (2.0 * PI * g->omc);
}

int qmc__scene_hit(const qmc__scene_geom *g, qmc_vec3 w, double *dist,
                   double *pdf_light)
{
    if (g->sphere) {
        double u = qmc__dot(w, g->a);
        /* The cone test is the hit test, so the light technique's support
         * and the set of directions that see the light are one set. */
        if (!(u >= g->cos_max))
            return 0;
        *dist = qmc__scene_sphere_dist(g, u);
        *pdf_light = cone_pdf(g);
        return 1;
    }
    double denom = qmc__dot(w, g->nl);
    if (!(denom < 0.0))
        return 0;
    double t = qmc__dot(qmc__sub(g->c, g->p), g->nl) / denom;
    if (!(t > 0.0) || !isfinite(t))
        return 0;
    qmc_vec3 q = qmc__sub(qmc__add(g->p, qmc__scale(w, t)), g->c);
    double s1 = qmc__dot(qmc__cross(q, g->e2), g->m) * g->inv_m2;
    double s2 = qmc__dot(qmc__cross(g->e1, q), g->m) * g->inv_m2;
    if (!(s1 >= 0.0 && s1 <= 1.0 && s2 >= 0.0 && s2 <= 1.0))
        return 0;
    *dist = t;
    *pdf_light = t * t / (g->area * -denom);
    return 1;
}

/* ---- techniques ----------------------------------------------------------------- */

double qmc__scene_pdf_brdf(const qmc__scene_geom *g, qmc_vec3 w)
{
    qmc_vec3 ln = qmc__v3(qmc__dot(w, g->n1), qmc__dot(w, g->n2),
                          qmc__dot(w, g->n));
    double p = g->p_diffuse * qmc_warp_pdf_cosine_hemisphere(ln);
    if (g->phong && g->p_diffuse < 1.0) {
        qmc_vec3 lr = qmc__v3(qmc__dot(w, g->r1), qmc__dot(w, g->r2),
                              qmc__dot(w, g->r));
        p += (1.0 - g->p_diffuse) * qmc_warp_pdf_power_cosine(lr, g->expo);
    }
    return p;
}

double qmc__scene_pdf_uniform(const qmc__scene_geom *g, qmc_vec3 w)
{
    return qmc_warp_pdf_hemisphere(qmc__v3(0.0, 0.0, qmc__dot(w, g->n)));
}

/* A direction from the BRDF technique; *pdf its combined density. */
qmc_vec3 qmc__scene_sample_brdf(const qmc__scene_geom *g, const double *u, double *pdf)
{
    qmc_vec2 uv = {u[0], u[1]};
    qmc_vec3 w;

    if (uv.x < g->p_diffuse) {
        /* One uniform both picks the lobe and drives it: rescaled to
         * [0, 1) within the chosen branch, it stays stratified. */
        uv.x = uv.x / g->p_diffuse;
        w = qmc__to_world(qmc_warp_sample_cosine_hemisphere(uv), g->n1, g->n2,
                          g->n);
    } else {
        qmc_vec3 l;
        uv.x = (uv.x - g->p_diffuse) / (1.0 - g->p_diffuse);
        if (qmc_warp_sample_power_cosine(uv, g->expo, &l) != 0) {
            *pdf = 0.0;
            return g->n;
        }
        w = qmc__to_world(l, g->r1, g->r2, g->r);
    }
    *pdf = qmc__scene_pdf_brdf(g, w);
    return w;
}

/* A direction from the light technique, with its distance and density. */
qmc_vec3 qmc__scene_sample_light(const qmc__scene_geom *g, const double *u,
                                 double *dist, double *pdf)
{
    qmc_vec2 uv = {u[0], u[1]};

    if (g->sphere) {
        /* Uniform in the cone (PBR3 13.6.4), in terms of 1 - cos so that
         * the sampled cone is the light's to the last digit: 1 - z is
         * uniform on [0, omc], sin^2 = (1 - z)(1 + z). */
        double t = uv.x * g->omc, phi = 2.0 * PI * uv.y;
        double sin_t = sqrt(t * (2.0 - t));
        qmc_vec3 l = qmc__v3(cos(phi) * sin_t, sin(phi) * sin_t, 1.0 - t);
        *dist = qmc__scene_sphere_dist(g, l.z);
        *pdf = cone_pdf(g);
        return qmc__to_world(l, g->a1, g->a2, g->a);
    }
    qmc_vec3 y = qmc__add(g->c, qmc__add(qmc__scale(g->e1, u[0]),
                                         qmc__scale(g->e2, u[1])));
    qmc_vec3 v = qmc__sub(y, g->p);
    double d = qmc__len(v);
    qmc_vec3 w = qmc__scale(v, 1.0 / d);
    double cos_l = -qmc__dot(w, g->nl);
    *dist = d;
    *pdf = cos_l > 0.0 ? d * d / (g->area * cos_l) : 0.0;
    return w;
}

/* Radiance along w from a technique that does not know where w lands. */
static double shade_traced(const qmc__scene_geom *g, qmc_vec3 w,
                           double *pdf_light)
{
    double d;
    *pdf_light = 0.0;
    if (!qmc__scene_hit(g, w, &d, pdf_light))
        return 0.0;
    return qmc__scene_shade(g, w, d);
}

/* ---- MIS ------------------------------------------------------------------------------ */

static int is_mis(qmc_scene_strategy st)
{
    return st == QMC_SCENE_MIS_BALANCE || st == QMC_SCENE_MIS_POWER ||
           st == QMC_SCENE_MIS_MAX;
}

double qmc_scene_mis_weight(qmc_scene_strategy st, double beta, double q_self,
                            double q_other)
{
    if (!is_mis(st) || !(q_self > 0.0))
        return 0.0;
    if (!(q_other > 0.0))
        return 1.0;
    switch (st) {
    case QMC_SCENE_MIS_BALANCE:
        return q_self >= q_other ? 1.0 / (1.0 + q_other / q_self)
                                 : (q_self / q_other) / (1.0 + q_self / q_other);
    case QMC_SCENE_MIS_POWER: {
        /* Ratios of at most 1, so no power overflows whatever beta is. */
        double b = beta == 0.0 ? QMC_SCENE_DEFAULT_BETA : beta;
        if (q_self >= q_other)
            return 1.0 / (1.0 + pow(q_other / q_self, b));
        double x = pow(q_self / q_other, b);
        return x / (1.0 + x);
    }
    default:
        return q_self > q_other ? 1.0 : q_self < q_other ? 0.0 : 0.5;
    }
}

/* ---- the estimators --------------------------------------------------------------- */

static double estimate(const qmc_scene_job *job, const qmc__scene_geom *g,
                       const double *x)
{
    double pdf, pl, d, v;
    qmc_vec3 w;

    switch (job->strategy) {
    case QMC_SCENE_UNIFORM:
        w = qmc__to_world(qmc_warp_sample_hemisphere((qmc_vec2){x[0], x[1]}),
                          g->n1, g->n2, g->n);
        return shade_traced(g, w, &pl) * (2.0 * PI);
    case QMC_SCENE_BRDF:
        w = qmc__scene_sample_brdf(g, x, &pdf);
        if (!(pdf > 0.0))
            return 0.0;
        return shade_traced(g, w, &pl) / pdf;
    case QMC_SCENE_LIGHT:
        w = qmc__scene_sample_light(g, x, &d, &pdf);
        if (!(pdf > 0.0))
            return 0.0;
        return qmc__scene_shade(g, w, d) / pdf;
    default:
        break;
    }
    /* Veach (1997), eq. 9.12: F = sum_i (1/c_i) sum_j w_i f / p_i. */
    double cb = job->c_brdf, cl = job->c_light, sum_b = 0.0, sum_l = 0.0;
    for (uint32_t j = 0; j < job->c_brdf; j++) {
        w = qmc__scene_sample_brdf(g, x + 2 * j, &pdf);
        if (!(pdf > 0.0))
            continue;
        v = shade_traced(g, w, &pl);
        if (v > 0.0)
            sum_b += qmc_scene_mis_weight(job->strategy, job->beta, cb * pdf,
                                          cl * pl) * v / pdf;
    }
    x += 2 * (size_t)job->c_brdf;
    for (uint32_t j = 0; j < job->c_light; j++) {
        w = qmc__scene_sample_light(g, x + 2 * j, &d, &pl);
        if (!(pl > 0.0))
            continue;
        v = qmc__scene_shade(g, w, d);
        if (v > 0.0)
            sum_l += qmc_scene_mis_weight(job->strategy, job->beta, cl * pl,
                                          cb * qmc__scene_pdf_brdf(g, w)) * v / pl;
    }
    return (cb > 0.0 ? sum_b / cb : 0.0) + (cl > 0.0 ? sum_l / cl : 0.0);
}

static void scene_eval(const void *ctx, const double *x, size_t n,
                       uint32_t dims, double *out)
{
    const qmc_scene_job *job = ctx;
    qmc__scene_geom g;

    qmc__scene_geom_init(&job->scene, &g);
    for (size_t i = 0; i < n; i++)
        out[i] = dims == job->integrand.dims ? estimate(job, &g, x + i * dims)
                                             : NAN;
}

/* ---- public API ------------------------------------------------------------------------ */

#define QMC__SCENE_ST_NAME(name, value, text) \
    case QMC_SCENE_##name:                     \
        return text;
const char *qmc_scene_strategy_name(qmc_scene_strategy st)
{
    switch (st) {
        QMC_SCENE_STRATEGY_MAP(QMC__SCENE_ST_NAME)
    }
    return "";
}
#undef QMC__SCENE_ST_NAME

#define QMC__SCENE_ST_INTEGRAND(name, value, text) \
    case QMC_SCENE_##name:                          \
        return "scene-" text;
static const char *integrand_name(qmc_scene_strategy st)
{
    switch (st) {
        QMC_SCENE_STRATEGY_MAP(QMC__SCENE_ST_INTEGRAND)
    }
    return "scene";
}
#undef QMC__SCENE_ST_INTEGRAND

int qmc_scene_strategy_parse(const char *name, qmc_scene_strategy *out)
{
    if (name == NULL || out == NULL)
        return QMC_EINVAL;
#define QMC__SCENE_ST_PARSE(sname, value, text) \
    if (strcmp(name, text) == 0) {               \
        *out = QMC_SCENE_##sname;                \
        return 0;                                \
    }
    QMC_SCENE_STRATEGY_MAP(QMC__SCENE_ST_PARSE)
#undef QMC__SCENE_ST_PARSE
    return QMC_EINVAL;
}

int qmc_scene_integrand(const qmc_scene *s, qmc_scene_strategy st,
                        double beta, uint32_t c_brdf, uint32_t c_light,
                        qmc_scene_job *job, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__scene_field field;
    double exact;
    int rc;

    qmc__msg_init(&m, why, why_bytes);
    if (job == NULL || s == NULL) {
        qmc__msg_str(&m, "no scene or job");
        return QMC_EINVAL;
    }
    memset(job, 0, sizeof *job);
    if (qmc_scene_strategy_name(st)[0] == '\0') {
        qmc__msg_str(&m, "unknown strategy");
        return QMC_EINVAL;
    }
    if ((rc = qmc__scene_validate(s, &field, &m)) != 0)
        return rc;
    if (is_mis(st)) {
        if ((uint64_t)c_brdf + c_light == 0) {
            qmc__msg_str(&m, "MIS needs c_brdf + c_light >= 1");
            return QMC_EINVAL;
        }
        if ((uint64_t)c_brdf + c_light > QMC_SCENE_MAX_SAMPLES) {
            qmc__msg_set(&m, "c_brdf + c_light exceeds ",
                         QMC_SCENE_MAX_SAMPLES, "");
            return QMC_ETOOBIG;
        }
        if (st == QMC_SCENE_MIS_POWER) {
            if (!isfinite(beta) || beta < 0.0) {
                qmc__msg_str(&m, "beta must be finite and > 0 (0: default 2)");
                return QMC_EINVAL;
            }
            job->beta = beta == 0.0 ? QMC_SCENE_DEFAULT_BETA : beta;
        } else {
            job->beta = st == QMC_SCENE_MIS_BALANCE ? 1.0 : 0.0;
        }
        job->c_brdf = c_brdf;
        job->c_light = c_light;
    } else {
        job->c_brdf = st == QMC_SCENE_LIGHT ? 0u : 1u;
        job->c_light = st == QMC_SCENE_LIGHT ? 1u : 0u;
    }
    job->scene = *s;
    job->strategy = st;
    job->samples = job->c_brdf + job->c_light;
    job->integrand.eval = scene_eval;
    job->integrand.ctx = job;
    job->integrand.dims = 2u * job->samples;
    job->integrand.smoothness = QMC_SMOOTH_DISCONTINUOUS;
    job->integrand.name = integrand_name(st);
    job->integrand.audit = qmc__scene_audit;
    if (qmc_scene_exact(s, &exact) == 0) {
        job->integrand.has_exact = 1;
        job->integrand.exact = exact;
        job->integrand.has_abs_integral = 1;
        job->integrand.abs_integral = exact;
    }
    return 0;
}

double qmc_scene_radiance(const qmc_scene *s, qmc_vec3 w)
{
    qmc__scene_geom g;
    double pl;
    double len = qmc__len(w);

    if (s == NULL || !(len > 0.0) || !isfinite(len))
        return 0.0;
    qmc__scene_geom_init(s, &g);
    return shade_traced(&g, qmc__scale(w, 1.0 / len), &pl);
}

double qmc_scene_pdf(const qmc_scene *s, qmc_scene_strategy st, qmc_vec3 w)
{
    qmc__scene_geom g;
    double d, pl = 0.0;
    double len = qmc__len(w);

    if (s == NULL || !(len > 0.0) || !isfinite(len))
        return 0.0;
    qmc__scene_geom_init(s, &g);
    w = qmc__scale(w, 1.0 / len);
    switch (st) {
    case QMC_SCENE_UNIFORM:
        return qmc__scene_pdf_uniform(&g, w);
    case QMC_SCENE_BRDF:
        return qmc__scene_pdf_brdf(&g, w);
    case QMC_SCENE_LIGHT:
        return qmc__scene_hit(&g, w, &d, &pl) ? pl : 0.0;
    default:
        return 0.0;
    }
}
