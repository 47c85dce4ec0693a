/* Native content filters for paramdds readers (optional extension).
 *
 * Cyclone calls a topic filter on its own receive thread while it holds the
 * reader's lock. A Python filter would then wait for the GIL, which a thread
 * inside the binding's take/write holds while it waits for that same lock: a
 * deadlock. These filters never touch Python: they read the serialized sample
 * and compare it with a table kept in C memory behind a leaf mutex (nothing is
 * ever called while holding it), which Python replaces whole when the set of
 * accepted values changes.
 *
 * The sample Cyclone hands a filter of a cyclonedds-python topic is the
 * binding's sample container: a pointer to the CDR bytes (4-byte encapsulation
 * header first) and their size. Every paramdds request, reply and state type
 * starts with `string<255> node_id`; replies follow it with `uint64 client_id`
 * and state samples with `string<255> name`. Encodings read:
 *
 *   CDR_BE/CDR_LE (XCDR1, @final):          header | node_id | ...
 *   PLAIN_CDR2_BE/LE (XCDR2, @final):       header | node_id | ...
 *   D_CDR2_BE/LE (XCDR2, @appendable):      header | DHEADER | node_id | ...
 *
 * Anything else (parameter lists, truncated or inconsistent bytes) is accepted:
 * the Python handler's own check stays behind every filter.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  const unsigned char *usample;
  size_t usample_size;
} sample_container_t;

enum { MODE_NODES = 0, MODE_CLIENT = 1, MODE_PRESENCE = 2 };

/* An immutable open-addressing hash set of byte strings, replaced whole. */
typedef struct {
  size_t mask;          /* capacity - 1, capacity a power of two */
  uint32_t *hashes;     /* 0 = empty slot */
  uint32_t *offsets;    /* into blob */
  uint32_t *lengths;
  unsigned char *blob;
} idset_t;

/* What Cyclone's filter reads. Once handed to Cyclone it is never freed: a reader's
 * C entity can outlive every Python object (the binding skips dds_delete for
 * entities collected in a reference cycle), so when the Python object goes the
 * state stays, empty and rejecting everything (nothing can take from that reader). */
typedef struct {
  pthread_mutex_t lock; /* leaf lock: nothing is called while holding it */
  int mode;
  bool installed;       /* handed to Cyclone: never freed */
  bool dead;            /* the Python object is gone: reject everything */
  idset_t *set;         /* NULL: accept every node id */
  uint64_t client_id;
  uint64_t accepted, rejected, unparsed;
} filter_state_t;

typedef struct {
  PyObject_HEAD
  filter_state_t *st;
} FilterObject;

/* ---- parsing ------------------------------------------------------------ */

typedef struct {
  const unsigned char *p;
  size_t size;
  size_t off;   /* absolute offset into p */
  bool le;
  bool v2;
} cursor_t;

static bool cursor_open(cursor_t *c, const unsigned char *p, size_t size)
{
  if (p == NULL || size < 8 || p[0] != 0)
    return false;
  bool dheader = false;
  switch (p[1]) {
    case 0x00: c->le = false; c->v2 = false; break; /* CDR_BE */
    case 0x01: c->le = true; c->v2 = false; break;  /* CDR_LE */
    case 0x06: c->le = false; c->v2 = true; break;  /* PLAIN_CDR2_BE */
    case 0x07: c->le = true; c->v2 = true; break;   /* PLAIN_CDR2_LE */
    case 0x08: c->le = false; c->v2 = true; dheader = true; break; /* D_CDR2_BE */
    case 0x09: c->le = true; c->v2 = true; dheader = true; break;  /* D_CDR2_LE */
    default: return false;
  }
  c->p = p;
  c->size = size;
  c->off = dheader ? 8 : 4;
  return true;
}

static bool cursor_align(cursor_t *c, size_t align)
{
  size_t rel = c->off - 4; /* alignment counts from the end of the header */
  size_t pad = (align - rel % align) % align;
  if (c->off + pad > c->size)
    return false;
  c->off += pad;
  return true;
}

static bool read_u32(cursor_t *c, uint32_t *out)
{
  if (!cursor_align(c, 4) || c->off + 4 > c->size)
    return false;
  const unsigned char *b = c->p + c->off;
  *out = c->le ? ((uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24)
               : ((uint32_t)b[3] | (uint32_t)b[2] << 8 | (uint32_t)b[1] << 16 | (uint32_t)b[0] << 24);
  c->off += 4;
  return true;
}

static bool read_u64(cursor_t *c, uint64_t *out)
{
  if (!cursor_align(c, c->v2 ? 4 : 8) || c->off + 8 > c->size)
    return false;
  const unsigned char *b = c->p + c->off;
  uint64_t v = 0;
  for (int i = 0; i < 8; i++)
    v |= (uint64_t)b[c->le ? i : 7 - i] << (8 * i);
  *out = v;
  c->off += 8;
  return true;
}

/* A CDR string: length (counting the NUL), bytes, NUL. */
static bool read_str(cursor_t *c, const unsigned char **s, uint32_t *len)
{
  uint32_t n;
  if (!read_u32(c, &n) || n == 0 || n > c->size - c->off || c->p[c->off + n - 1] != 0)
    return false;
  *s = c->p + c->off;
  *len = n - 1;
  c->off += n;
  return true;
}

/* ---- the id set --------------------------------------------------------- */

static uint32_t hash_bytes(const unsigned char *s, size_t n)
{
  uint32_t h = 2166136261u; /* FNV-1a */
  for (size_t i = 0; i < n; i++) {
    h ^= s[i];
    h *= 16777619u;
  }
  return h ? h : 1;
}

static void idset_free(idset_t *set)
{
  if (set == NULL)
    return;
  free(set->hashes);
  free(set->offsets);
  free(set->lengths);
  free(set->blob);
  free(set);
}

static bool idset_contains(const idset_t *set, const unsigned char *s, uint32_t n)
{
  uint32_t h = hash_bytes(s, n);
  for (size_t i = h & set->mask;; i = (i + 1) & set->mask) {
    if (set->hashes[i] == 0)
      return false;
    if (set->hashes[i] == h && set->lengths[i] == n && memcmp(set->blob + set->offsets[i], s, n) == 0)
      return true;
  }
}

/* Builds a set from a sequence of bytes objects; NULL with an exception set on error. */
static idset_t *idset_build(PyObject *items)
{
  PyObject *seq = PySequence_Fast(items, "ids must be a sequence of bytes");
  if (seq == NULL)
    return NULL;
  Py_ssize_t count = PySequence_Fast_GET_SIZE(seq);
  size_t total = 0;
  for (Py_ssize_t i = 0; i < count; i++) {
    PyObject *item = PySequence_Fast_GET_ITEM(seq, i);
    if (!PyBytes_Check(item)) {
      PyErr_SetString(PyExc_TypeError, "ids must be bytes");
      Py_DECREF(seq);
      return NULL;
    }
    total += (size_t)PyBytes_GET_SIZE(item);
  }
  if (total > UINT32_MAX / 2 || (size_t)count > UINT32_MAX / 4) {
    PyErr_SetString(PyExc_OverflowError, "too many ids");
    Py_DECREF(seq);
    return NULL;
  }
  size_t cap = 8;
  while (cap < 2 * (size_t)count + 2)
    cap *= 2;
  idset_t *set = calloc(1, sizeof(*set));
  if (set != NULL) {
    set->mask = cap - 1;
    set->hashes = calloc(cap, sizeof(uint32_t));
    set->offsets = calloc(cap, sizeof(uint32_t));
    set->lengths = calloc(cap, sizeof(uint32_t));
    set->blob = malloc(total ? total : 1);
  }
  if (set == NULL || !set->hashes || !set->offsets || !set->lengths || !set->blob) {
    idset_free(set);
    Py_DECREF(seq);
    PyErr_NoMemory();
    return NULL;
  }
  size_t used = 0;
  for (Py_ssize_t i = 0; i < count; i++) {
    PyObject *item = PySequence_Fast_GET_ITEM(seq, i);
    const unsigned char *s = (const unsigned char *)PyBytes_AS_STRING(item);
    uint32_t n = (uint32_t)PyBytes_GET_SIZE(item);
    if (idset_contains(set, s, n))
      continue;
    uint32_t h = hash_bytes(s, n);
    size_t slot = h & set->mask;
    while (set->hashes[slot] != 0)
      slot = (slot + 1) & set->mask;
    memcpy(set->blob + used, s, n);
    set->hashes[slot] = h;
    set->offsets[slot] = (uint32_t)used;
    set->lengths[slot] = n;
    used += n;
  }
  Py_DECREF(seq);
  return set;
}

/* ---- the filter Cyclone calls ------------------------------------------- */

static bool decide(const filter_state_t *f, const sample_container_t *sample, bool *understood)
{
  cursor_t c;
  const unsigned char *node;
  uint32_t node_len;
  *understood = false;
  if (f->dead) {
    *understood = true;
    return false;
  }
  if (sample == NULL || !cursor_open(&c, sample->usample, sample->usample_size) ||
      !read_str(&c, &node, &node_len))
    return true;
  switch (f->mode) {
    case MODE_NODES:
      *understood = true;
      return f->set == NULL || idset_contains(f->set, node, node_len);
    case MODE_CLIENT: {
      uint64_t client_id;
      if (!read_u64(&c, &client_id))
        return true;
      *understood = true;
      return client_id == f->client_id;
    }
    case MODE_PRESENCE: {
      const unsigned char *name;
      uint32_t name_len;
      if (!read_str(&c, &name, &name_len))
        return true;
      *understood = true;
      return name_len == 0 && (f->set == NULL || idset_contains(f->set, node, node_len));
    }
    default:
      return true;
  }
}

static bool paramdds_filter(const void *sample, void *arg)
{
  filter_state_t *f = (filter_state_t *)arg;
  bool understood, accept;
  pthread_mutex_lock(&f->lock);
  accept = decide(f, (const sample_container_t *)sample, &understood);
  if (!understood)
    f->unparsed++;
  else if (accept)
    f->accepted++;
  else
    f->rejected++;
  pthread_mutex_unlock(&f->lock);
  return accept;
}

/* ---- the Python object -------------------------------------------------- */

static int Filter_init(FilterObject *self, PyObject *args, PyObject *kwds)
{
  static char *kwlist[] = {"mode", NULL};
  int mode;
  if (!PyArg_ParseTupleAndKeywords(args, kwds, "i", kwlist, &mode))
    return -1;
  if (mode != MODE_NODES && mode != MODE_CLIENT && mode != MODE_PRESENCE) {
    PyErr_Format(PyExc_ValueError, "unknown filter mode %d", mode);
    return -1;
  }
  pthread_mutex_lock(&self->st->lock);
  self->st->mode = mode;
  pthread_mutex_unlock(&self->st->lock);
  return 0;
}

static PyObject *Filter_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
  (void)args;
  (void)kwds;
  FilterObject *self = (FilterObject *)type->tp_alloc(type, 0);
  if (self == NULL)
    return NULL;
  self->st = calloc(1, sizeof(filter_state_t));
  if (self->st == NULL || pthread_mutex_init(&self->st->lock, NULL) != 0) {
    free(self->st);
    self->st = NULL;
    Py_DECREF(self);
    return PyErr_NoMemory();
  }
  return (PyObject *)self;
}

static void Filter_dealloc(FilterObject *self)
{
  filter_state_t *st = self->st;
  if (st != NULL) {
    idset_t *old;
    bool installed;
    pthread_mutex_lock(&st->lock);
    old = st->set;
    st->set = NULL;
    st->dead = true;
    installed = st->installed;
    pthread_mutex_unlock(&st->lock);
    idset_free(old);
    if (!installed) {
      pthread_mutex_destroy(&st->lock);
      free(st);
    }
  }
  Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *Filter_set_ids(FilterObject *self, PyObject *items)
{
  idset_t *fresh = NULL;
  if (items != Py_None && (fresh = idset_build(items)) == NULL)
    return NULL;
  idset_t *old;
  Py_BEGIN_ALLOW_THREADS
  pthread_mutex_lock(&self->st->lock);
  old = self->st->set;
  self->st->set = fresh;
  pthread_mutex_unlock(&self->st->lock);
  Py_END_ALLOW_THREADS
  idset_free(old);
  Py_RETURN_NONE;
}

static PyObject *Filter_set_client_id(FilterObject *self, PyObject *arg)
{
  unsigned long long value = PyLong_AsUnsignedLongLong(arg);
  if (value == (unsigned long long)-1 && PyErr_Occurred())
    return NULL;
  Py_BEGIN_ALLOW_THREADS
  pthread_mutex_lock(&self->st->lock);
  self->st->client_id = (uint64_t)value;
  pthread_mutex_unlock(&self->st->lock);
  Py_END_ALLOW_THREADS
  Py_RETURN_NONE;
}

static PyObject *Filter_check(FilterObject *self, PyObject *arg)
{
  Py_buffer view;
  if (PyObject_GetBuffer(arg, &view, PyBUF_SIMPLE) < 0)
    return NULL;
  sample_container_t sample = {(const unsigned char *)view.buf, (size_t)view.len};
  bool accept = paramdds_filter(&sample, self->st);
  PyBuffer_Release(&view);
  return PyBool_FromLong(accept);
}

static PyObject *Filter_counts(FilterObject *self, PyObject *unused)
{
  (void)unused;
  uint64_t a, r, u;
  pthread_mutex_lock(&self->st->lock);
  a = self->st->accepted;
  r = self->st->rejected;
  u = self->st->unparsed;
  pthread_mutex_unlock(&self->st->lock);
  return Py_BuildValue("(KKK)", (unsigned long long)a, (unsigned long long)r, (unsigned long long)u);
}

static PyObject *Filter_function(FilterObject *self, PyObject *unused)
{
  (void)self;
  (void)unused;
  return PyLong_FromVoidPtr((void *)&paramdds_filter);
}

static PyObject *Filter_argument(FilterObject *self, PyObject *unused)
{
  (void)unused;
  pthread_mutex_lock(&self->st->lock);
  self->st->installed = true; /* from now on Cyclone may hold it: never freed */
  pthread_mutex_unlock(&self->st->lock);
  return PyLong_FromVoidPtr((void *)self->st);
}

static PyMethodDef Filter_methods[] = {
    {"set_ids", (PyCFunction)Filter_set_ids, METH_O,
     "Replace the accepted ids (a sequence of bytes; None accepts every id)."},
    {"set_client_id", (PyCFunction)Filter_set_client_id, METH_O, "The client id a reply must carry."},
    {"check", (PyCFunction)Filter_check, METH_O, "Run the filter on CDR bytes (header included)."},
    {"counts", (PyCFunction)Filter_counts, METH_NOARGS, "(accepted, rejected, not understood) so far."},
    {"function", (PyCFunction)Filter_function, METH_NOARGS, "Address of the C filter function."},
    {"argument", (PyCFunction)Filter_argument, METH_NOARGS, "Address of the filter's argument (marks it installed: kept for the process's life)."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject FilterType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "paramdds.dds._nodefilter.Filter",
    .tp_doc = "A native topic filter: Filter(mode) with MODE_NODES, MODE_CLIENT or MODE_PRESENCE.",
    .tp_basicsize = sizeof(FilterObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = Filter_new,
    .tp_init = (initproc)Filter_init,
    .tp_dealloc = (destructor)Filter_dealloc,
    .tp_methods = Filter_methods,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_nodefilter", "Native content filters for paramdds readers.", -1, NULL,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__nodefilter(void)
{
  if (PyType_Ready(&FilterType) < 0)
    return NULL;
  PyObject *m = PyModule_Create(&module);
  if (m == NULL)
    return NULL;
  Py_INCREF(&FilterType);
  if (PyModule_AddObject(m, "Filter", (PyObject *)&FilterType) < 0 ||
      PyModule_AddIntConstant(m, "MODE_NODES", MODE_NODES) < 0 ||
      PyModule_AddIntConstant(m, "MODE_CLIENT", MODE_CLIENT) < 0 ||
      PyModule_AddIntConstant(m, "MODE_PRESENCE", MODE_PRESENCE) < 0) {
    Py_DECREF(&FilterType);
    Py_DECREF(m);
    return NULL;
  }
  return m;
}
