/*
 * A paramdds participant in C on Eclipse Cyclone DDS (Debian's 0.10.2 is enough),
 * built from idl/paramdds.idl with idlc at build time. No paramdds code: only the
 * IDL and the QoS profiles of qos/DDS_QOS_PROFILES.xml, written out below.
 *
 *   paramdds_peer node NODE_ID          host four parameters; answer get/list/set
 *   paramdds_peer monitor [SECONDS]     late-join ParameterEvents and print every node's state
 *   paramdds_peer get NODE NAME...      ask a node for values
 *   paramdds_peer set NODE NAME=VALUE...  (VALUE: true/false, an integer, a double, else a string)
 *   paramdds_peer list NODE
 *
 * Domain: $PARAMDDS_DOMAIN (default 1); Cyclone's configuration: $CYCLONEDDS_URI.
 * Output, one line each (values as JSON, after their paramdds type name):
 *   PARAM node name type value | NODE node host pid revision count | VALUE name type value
 *   BLAME node name via verified revision who (after a PARAM whose sample says who changed it)
 *   MISSING name code | RESULT name OK | RESULT name FAILED code reason | NAME name | READY
 *   REFUSED code reason (a set refused whole, e.g. EXPIRED)
 * Exit status: 0 success, 1 refused or missing, 2 usage, 3 no answer within 5 s (get, list),
 * 5 a set without an answer within 5 s (its outcome is unknown: it may have been applied).
 * A set carries a deadline (5 s after it is sent, less 0.2 s for the reply to travel back); the node
 * refuses a set past its deadline by its own clock with EXPIRED and applies nothing.
 *
 * Blame: the node stamps each parameter's state with who changed it and through what, as the
 * asker claimed them (unverified: no DDS Security here); the values it starts with are its own
 * ($PARAMDDS_AS, else USER@host, via "start", verified: no claim crossed a wire). A set this
 * client sends says the same identity, via "api". The node keeps no history: a history query
 * is answered as a get, history_kept FALSE.
 */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "dds/dds.h"
#include "paramdds.h"

#define ANSWER_TIMEOUT DDS_SECS (5)
#define REPLY_ALLOWANCE DDS_MSECS (200) /* a set's deadline is this long before the caller stops waiting */
#define MAX_PARAMS 8
#define ANSWERED 64 /* answers to sets kept: a resent set gets its first answer, not a second application */

static const char *TYPE_NAMES[] = {"not_set", "bool", "integer", "double", "string",
                                   "byte_array", "bool_array", "integer_array", "double_array",
                                   "string_array"};

/* ---- QoS: the profiles of qos/DDS_QOS_PROFILES.xml ---------------------------------------- */

static dds_qos_t *qos_state (void)
{
  dds_qos_t *q = dds_create_qos ();
  dds_qset_reliability (q, DDS_RELIABILITY_RELIABLE, DDS_SECS (1));
  dds_qset_durability (q, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history (q, DDS_HISTORY_KEEP_LAST, 1);
  return q;
}

static dds_qos_t *qos_state_writer (void)
{
  dds_qos_t *q = qos_state ();
  dds_qset_liveliness (q, DDS_LIVELINESS_AUTOMATIC, DDS_SECS (1)); /* a killed node is offline in ~1 s */
  dds_qset_writer_data_lifecycle (q, false); /* a graceful stop is "no writers", not "deleted" */
  return q;
}

/* Request and Reply: reliable, volatile; writers keep a deep history, readers keep all. */
static dds_qos_t *qos_call_writer (void)
{
  dds_qos_t *q = dds_create_qos ();
  dds_qset_reliability (q, DDS_RELIABILITY_RELIABLE, DDS_SECS (1));
  dds_qset_durability (q, DDS_DURABILITY_VOLATILE);
  dds_qset_history (q, DDS_HISTORY_KEEP_LAST, 4096);
  return q;
}

static dds_qos_t *qos_call_reader (void)
{
  dds_qos_t *q = dds_create_qos ();
  dds_qset_reliability (q, DDS_RELIABILITY_RELIABLE, DDS_SECS (1));
  dds_qset_durability (q, DDS_DURABILITY_VOLATILE);
  dds_qset_history (q, DDS_HISTORY_KEEP_ALL, 0);
  dds_qset_resource_limits (q, 10000, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  return q;
}

static dds_entity_t check (dds_entity_t e, const char *what)
{
  if (e < 0)
  {
    fprintf (stderr, "paramdds_peer: %s: %s\n", what, dds_strretcode (e));
    exit (4);
  }
  return e;
}

static dds_entity_t endpoint (dds_entity_t dp, const char *topic_name, const dds_topic_descriptor_t *desc,
                              bool writer, dds_qos_t *qos)
{
  dds_entity_t topic = check (dds_create_topic (dp, desc, topic_name, NULL, NULL), topic_name);
  dds_entity_t e = writer ? dds_create_writer (dp, topic, qos, NULL) : dds_create_reader (dp, topic, qos, NULL);
  dds_delete_qos (qos);
  return check (e, topic_name);
}

/* ---- values ---------------------------------------------------------------------------------- */

static void print_json_string (const char *s)
{
  putchar ('"');
  for (const unsigned char *p = (const unsigned char *) s; *p; p++)
  {
    if (*p == '"' || *p == '\\')
      printf ("\\%c", *p);
    else if (*p < 0x20)
      printf ("\\u%04x", *p);
    else
      putchar (*p);
  }
  putchar ('"');
}

static void print_value (const paramdds_ParameterValue *v)
{
  printf ("%s ", v->type < 10 ? TYPE_NAMES[v->type] : "unknown");
  switch (v->type)
  {
    case 1: printf ("%s", v->bool_value ? "true" : "false"); break;
    case 2: printf ("%lld", (long long) v->integer_value); break;
    case 3: printf ("%.17g", v->double_value); break;
    case 4: print_json_string (v->string_value); break;
    case 5: case 6: case 7: case 8: case 9:
      putchar ('[');
      for (uint32_t i = 0; ; i++)
      {
        uint32_t n = v->type == 5 ? v->byte_array_value._length : v->type == 6 ? v->bool_array_value._length
                   : v->type == 7 ? v->integer_array_value._length : v->type == 8 ? v->double_array_value._length
                   : v->string_array_value._length;
        if (i >= n)
          break;
        if (i)
          putchar (',');
        if (v->type == 5) printf ("%u", v->byte_array_value._buffer[i]);
        else if (v->type == 6) printf ("%s", v->bool_array_value._buffer[i] ? "true" : "false");
        else if (v->type == 7) printf ("%lld", (long long) v->integer_array_value._buffer[i]);
        else if (v->type == 8) printf ("%.17g", v->double_array_value._buffer[i]);
        else print_json_string (v->string_array_value._buffer[i]);
      }
      putchar (']');
      break;
    default: printf ("null"); break;
  }
}

/* "true"/"false", an integer, a double, else a string (borrowed from text) */
static void parse_value (char *text, paramdds_ParameterValue *v)
{
  char *end;
  memset (v, 0, sizeof (*v));
  v->string_value = "";
  if (strcmp (text, "true") == 0 || strcmp (text, "false") == 0)
  {
    v->type = 1;
    v->bool_value = text[0] == 't';
    return;
  }
  long long i = strtoll (text, &end, 10);
  if (*text && *end == '\0')
  {
    v->type = 2;
    v->integer_value = i;
    return;
  }
  double d = strtod (text, &end);
  if (*text && *end == '\0')
  {
    v->type = 3;
    v->double_value = d;
    return;
  }
  v->type = 4;
  v->string_value = text;
}

/* ---- node ------------------------------------------------------------------------------------ */

static volatile sig_atomic_t stop;
static void on_signal (int sig) { (void) sig; stop = 1; }

struct param
{
  char name[64];
  paramdds_ParameterValue value;
  char who[128], via[16]; /* who last changed it, through what; "" when unknown */
  bool verified;          /* its own start value (no claim crossed a wire); a set's asker only claims */
  paramdds_Time stamp;    /* when */
  int64_t revision;       /* at which revision */
};

struct node
{
  char id[256];
  struct param params[MAX_PARAMS];
  int count;
  int64_t revision;
  uint64_t incarnation; /* random, non-zero, new on every start: (incarnation, revision) never repeats */
  dds_entity_t state;
  char host[256];
  paramdds_SetParametersResponse answered[ANSWERED]; /* copies, their strings on the heap */
  bool kept[ANSWERED];
  int next_answer;
};

static struct param *find (struct node *n, const char *name)
{
  for (int i = 0; i < n->count; i++)
    if (strcmp (n->params[i].name, name) == 0)
      return &n->params[i];
  return NULL;
}

static uint64_t new_incarnation (void)
{
  uint64_t x = 0;
  FILE *f = fopen ("/dev/urandom", "rb");
  if (f == NULL || fread (&x, sizeof (x), 1, f) != 1)
    x = ((uint64_t) time (NULL) << 32) ^ (uint64_t) getpid ();
  if (f != NULL)
    fclose (f);
  return x ? x : 1;
}

/* $PARAMDDS_AS, else USER@host: the identity this program claims (as paramdds's default) */
static void local_identity (char *out, size_t size)
{
  const char *as = getenv ("PARAMDDS_AS"), *user = getenv ("USER");
  char host[128] = "";
  gethostname (host, sizeof (host) - 1);
  if (as != NULL && as[0])
    snprintf (out, size, "%s", as);
  else
    snprintf (out, size, "%s@%s", user != NULL && user[0] ? user : "unknown", host);
}

static void stamp_now (paramdds_Time *t)
{
  struct timespec ts;
  clock_gettime (CLOCK_REALTIME, &ts);
  t->sec = (int32_t) ts.tv_sec;
  t->nanosec = (uint32_t) ts.tv_nsec;
}

static void publish_param (struct node *n, const struct param *p)
{
  paramdds_ParameterEvent ev;
  memset (&ev, 0, sizeof (ev));
  snprintf (ev.node_id, sizeof (ev.node_id), "%s", n->id);
  snprintf (ev.name, sizeof (ev.name), "%s", p->name);
  ev.kind = 0;
  ev.revision = p->revision;
  ev.incarnation = n->incarnation;
  ev.stamp = p->stamp;
  ev.value = p->value;
  ev.host = "";
  ev.who = (char *) p->who; /* the blame members: "" (never NULL) when unknown */
  ev.verified = p->verified;
  ev.via = (char *) p->via;
  check (dds_write (n->state, &ev), "write ParameterEvents");
}

static void publish_presence (struct node *n)
{
  paramdds_ParameterEvent ev;
  memset (&ev, 0, sizeof (ev));
  snprintf (ev.node_id, sizeof (ev.node_id), "%s", n->id);
  ev.kind = 1;
  ev.revision = n->revision;
  ev.incarnation = n->incarnation;
  stamp_now (&ev.stamp);
  ev.value.string_value = "";
  ev.host = n->host;
  ev.who = ev.via = ""; /* presence carries no blame */
  ev.pid = (int32_t) getpid ();
  ev.parameter_count = (uint32_t) n->count;
  check (dds_write (n->state, &ev), "write presence");
}

static void answer_get (struct node *n, const paramdds_GetParametersRequest *rq, dds_entity_t wr)
{
  paramdds_GetParametersResponse rp;
  paramdds_GetParameterResult results[64];
  paramdds_ParameterDescriptor descs[64];
  paramdds_LastChange changes[64];
  uint32_t count = rq->names._length < 64 ? rq->names._length : 64;
  memset (&rp, 0, sizeof (rp));
  memset (results, 0, sizeof (results));
  memset (descs, 0, sizeof (descs));
  memset (changes, 0, sizeof (changes));
  /* A history query (rq->history._length == 1) is answered as a get: this node keeps no history,
     and history_kept left FALSE (with history_more, history_compacted and an empty history) says
     so to the asker. */
  snprintf (rp.node_id, sizeof (rp.node_id), "%s", n->id);
  rp.client_id = rq->client_id; /* echoed: each client reads only its own replies */
  rp.request_id = rq->request_id;
  rp.revision = n->revision;
  rp.incarnation = n->incarnation;
  rp.code = rp.reason = "";
  for (uint32_t i = 0; i < count; i++)
  {
    paramdds_GetParameterResult *r = &results[i];
    struct param *p = find (n, rq->names._buffer[i]);
    r->name = rq->names._buffer[i];
    r->code = r->reason = "";
    r->value.string_value = "";
    if (p == NULL)
    {
      r->code = "NOT_FOUND";
      r->reason = "no such parameter on this node";
      continue;
    }
    r->value = p->value;
    if (rq->with_descriptors)
    {
      descs[i].name = p->name;
      descs[i].type = p->value.type;
      descs[i].description = descs[i].additional_constraints = "";
      r->descriptor._length = r->descriptor._maximum = 1;
      r->descriptor._buffer = &descs[i];
      if (p->who[0] == '\0' && p->via[0] == '\0')
        continue; /* who changed it last is not known: no last change */
      changes[i].who = p->who; /* the parameter's last change, as its state says it */
      changes[i].verified = p->verified;
      changes[i].via = p->via;
      changes[i].stamp = p->stamp;
      changes[i].revision = p->revision;
      r->last_change._length = r->last_change._maximum = 1;
      r->last_change._buffer = &changes[i];
    }
  }
  rp.results._length = rp.results._maximum = count;
  rp.results._buffer = results;
  check (dds_write (wr, &rp), "write GetParametersResponse");
}

static void answer_list (struct node *n, const paramdds_ListParametersRequest *rq, dds_entity_t wr)
{
  paramdds_ListParametersResponse rp;
  char *names[MAX_PARAMS];
  uint32_t count = 0;
  memset (&rp, 0, sizeof (rp));
  snprintf (rp.node_id, sizeof (rp.node_id), "%s", n->id);
  rp.client_id = rq->client_id;
  rp.request_id = rq->request_id;
  rp.revision = n->revision;
  rp.incarnation = n->incarnation;
  rp.code = rp.reason = "";
  for (int i = 0; i < n->count; i++)
  {
    bool wanted = rq->prefixes._length == 0;
    for (uint32_t k = 0; k < rq->prefixes._length && !wanted; k++)
    {
      size_t len = strlen (rq->prefixes._buffer[k]);
      wanted = strncmp (n->params[i].name, rq->prefixes._buffer[k], len) == 0
               && (n->params[i].name[len] == '\0' || n->params[i].name[len] == '.');
    }
    if (wanted) /* depth is not applied: this node's names are all two levels deep */
      names[count++] = n->params[i].name;
  }
  rp.names._length = rp.names._maximum = count;
  rp.names._buffer = names;
  check (dds_write (wr, &rp), "write ListParametersResponse");
}

/* Write a set's answer and keep a copy (the oldest kept one makes room). */
static void reply_set (struct node *n, const paramdds_SetParametersResponse *rp, dds_entity_t wr)
{
  check (dds_write (wr, rp), "write SetParametersResponse");
  paramdds_SetParametersResponse *kept = &n->answered[n->next_answer];
  if (n->kept[n->next_answer])
    dds_sample_free (kept, &paramdds_SetParametersResponse_desc, DDS_FREE_CONTENTS);
  n->kept[n->next_answer] = true;
  n->next_answer = (n->next_answer + 1) % ANSWERED;
  *kept = *rp; /* the node id (an array), ids and numbers; the strings and results copied below */
  kept->code = dds_string_dup (rp->code);
  kept->reason = dds_string_dup (rp->reason);
  kept->results._buffer = dds_alloc ((rp->results._length + 1) * sizeof (*rp->results._buffer));
  kept->results._release = true;
  for (uint32_t i = 0; i < rp->results._length; i++)
  {
    const paramdds_SetParameterResult *r = &rp->results._buffer[i];
    paramdds_SetParameterResult *k = &kept->results._buffer[i];
    k->name = dds_string_dup (r->name);
    k->successful = r->successful;
    k->reason = dds_string_dup (r->reason);
    k->code = dds_string_dup (r->code);
  }
}

static void answer_set (struct node *n, const paramdds_SetParametersRequest *rq, dds_entity_t wr)
{
  for (int i = 0; i < ANSWERED; i++) /* a resent set: its first answer again, nothing applied twice */
    if (n->kept[i] && n->answered[i].client_id == rq->client_id
        && n->answered[i].request_id == rq->request_id)
    {
      check (dds_write (wr, &n->answered[i]), "write SetParametersResponse");
      return;
    }

  paramdds_SetParametersResponse rp;
  paramdds_SetParameterResult results[64];
  uint32_t count = rq->parameters._length < 64 ? rq->parameters._length : 64;
  bool all_ok = true;
  memset (&rp, 0, sizeof (rp));
  memset (results, 0, sizeof (results));
  snprintf (rp.node_id, sizeof (rp.node_id), "%s", n->id);
  rp.client_id = rq->client_id;
  rp.request_id = rq->request_id;
  rp.code = rp.reason = "";
  dds_time_t now = dds_time ();
  if (rq->deadline != 0 && now > rq->deadline) /* past the caller's deadline by our clock: apply nothing */
  {
    char reason[200];
    snprintf (reason, sizeof (reason),
              "not applied: it arrived %.3f s after its deadline by this host's clock; are the two hosts' "
              "clocks in sync?", (double) (now - rq->deadline) / 1e9);
    rp.code = "EXPIRED", rp.reason = reason;
    rp.revision = n->revision;
    rp.incarnation = n->incarnation;
    reply_set (n, &rp, wr);
    return;
  }
  for (uint32_t i = 0; i < count; i++) /* validate everything first: an atomic set is all or nothing */
  {
    const paramdds_Parameter *in = &rq->parameters._buffer[i];
    struct param *p = find (n, in->name);
    paramdds_SetParameterResult *r = &results[i];
    r->name = in->name;
    r->successful = true;
    r->code = r->reason = "";
    if ((rq->expected_incarnation != 0 && rq->expected_incarnation != n->incarnation)
        || (rq->expected_revision >= 0 && rq->expected_revision != n->revision))
      r->code = "CONFLICT", r->reason = "the node's revision has moved on";
    else if (p == NULL)
      r->code = "NOT_FOUND", r->reason = "no such parameter on this node";
    else if (in->value.type != p->value.type || in->value.type < 1 || in->value.type > 4)
      r->code = "TYPE_MISMATCH", r->reason = "this node takes only a value of the parameter's type";
    r->successful = r->code[0] == '\0';
    all_ok = all_ok && r->successful;
  }
  bool changed = false;
  for (uint32_t i = 0; i < count; i++)
  {
    if (!results[i].successful)
      continue;
    if (rq->atomic && !all_ok)
    {
      results[i].successful = false;
      results[i].code = "INVALID_VALUE";
      results[i].reason = "another parameter of this atomic set was refused";
      continue;
    }
    struct param *p = find (n, rq->parameters._buffer[i].name);
    const paramdds_ParameterValue *v = &rq->parameters._buffer[i].value;
    if (p->value.type == 4)
    {
      dds_free (p->value.string_value);
      p->value.string_value = dds_string_dup (v->string_value);
    }
    else
    {
      p->value.bool_value = v->bool_value;
      p->value.integer_value = v->integer_value;
      p->value.double_value = v->double_value;
    }
    if (!changed)
      n->revision++, changed = true;
    snprintf (p->who, sizeof (p->who), "%s", rq->who); /* the asker's claim: recorded, not verified */
    snprintf (p->via, sizeof (p->via), "%s", rq->via);
    p->verified = false;
    stamp_now (&p->stamp);
    p->revision = n->revision;
    publish_param (n, p); /* the new state, with the revision of this set */
    printf ("SET %s\n", p->name);
  }
  if (changed)
    publish_presence (n);
  rp.revision = n->revision;
  rp.incarnation = n->incarnation;
  rp.results._length = rp.results._maximum = count;
  rp.results._buffer = results;
  reply_set (n, &rp, wr);
  fflush (stdout);
}

static int run_node (dds_entity_t dp, const char *id)
{
  struct node n;
  memset (&n, 0, sizeof (n));
  snprintf (n.id, sizeof (n.id), "%s", id);
  gethostname (n.host, sizeof (n.host) - 1);
  n.revision = 1;
  n.incarnation = new_incarnation ();
  const char *names[] = {"c.speed", "c.count", "c.label", "c.enabled"};
  for (int i = 0; i < 4; i++)
  {
    snprintf (n.params[i].name, sizeof (n.params[i].name), "%s", names[i]);
    n.params[i].value.string_value = dds_string_dup (i == 2 ? "cyclone-c" : "");
  }
  n.params[0].value.type = 3, n.params[0].value.double_value = 1.5;
  n.params[1].value.type = 2, n.params[1].value.integer_value = 3;
  n.params[2].value.type = 4;
  n.params[3].value.type = 1, n.params[3].value.bool_value = true;
  n.count = 4;
  for (int i = 0; i < n.count; i++) /* the values it starts with: its own */
  {
    local_identity (n.params[i].who, sizeof (n.params[i].who));
    snprintf (n.params[i].via, sizeof (n.params[i].via), "start");
    n.params[i].verified = true;
    stamp_now (&n.params[i].stamp);
    n.params[i].revision = n.revision;
  }

  n.state = endpoint (dp, "ParameterEvents", &paramdds_ParameterEvent_desc, true, qos_state_writer ());
  dds_entity_t get_rq = endpoint (dp, "GetParametersRequest", &paramdds_GetParametersRequest_desc, false, qos_call_reader ());
  dds_entity_t set_rq = endpoint (dp, "SetParametersRequest", &paramdds_SetParametersRequest_desc, false, qos_call_reader ());
  dds_entity_t list_rq = endpoint (dp, "ListParametersRequest", &paramdds_ListParametersRequest_desc, false, qos_call_reader ());
  dds_entity_t get_rp = endpoint (dp, "GetParametersResponse", &paramdds_GetParametersResponse_desc, true, qos_call_writer ());
  dds_entity_t set_rp = endpoint (dp, "SetParametersResponse", &paramdds_SetParametersResponse_desc, true, qos_call_writer ());
  dds_entity_t list_rp = endpoint (dp, "ListParametersResponse", &paramdds_ListParametersResponse_desc, true, qos_call_writer ());
  for (int i = 0; i < n.count; i++)
    publish_param (&n, &n.params[i]);
  publish_presence (&n);

  dds_entity_t ws = check (dds_create_waitset (dp), "waitset");
  dds_entity_t readers[3] = {get_rq, set_rq, list_rq};
  for (int i = 0; i < 3; i++)
    check (dds_waitset_attach (ws, check (dds_create_readcondition (readers[i], DDS_ANY_STATE), "condition"), i), "attach");
  signal (SIGTERM, on_signal);
  signal (SIGINT, on_signal);
  printf ("READY\n");
  fflush (stdout);
  while (!stop)
  {
    dds_waitset_wait (ws, NULL, 0, DDS_MSECS (200)); /* wakes up for a request, or to check for a signal */
    void *samples[16] = {NULL};
    dds_sample_info_t infos[16];
    dds_return_t got;
    while ((got = dds_take (get_rq, samples, infos, 16, 16)) > 0)
    {
      for (int i = 0; i < got; i++)
        if (infos[i].valid_data && strcmp (((paramdds_GetParametersRequest *) samples[i])->node_id, n.id) == 0)
          answer_get (&n, samples[i], get_rp);
      dds_return_loan (get_rq, samples, got);
    }
    while ((got = dds_take (list_rq, samples, infos, 16, 16)) > 0)
    {
      for (int i = 0; i < got; i++)
        if (infos[i].valid_data && strcmp (((paramdds_ListParametersRequest *) samples[i])->node_id, n.id) == 0)
          answer_list (&n, samples[i], list_rp);
      dds_return_loan (list_rq, samples, got);
    }
    while ((got = dds_take (set_rq, samples, infos, 16, 16)) > 0)
    {
      for (int i = 0; i < got; i++)
      {
        const paramdds_SetParametersRequest *rq = samples[i];
        /* retained samples are assignments (TRANSIENT_LOCAL, another path): not handled here */
        if (infos[i].valid_data && !rq->retained && strcmp (rq->node_id, n.id) == 0)
          answer_set (&n, rq, set_rp);
      }
      dds_return_loan (set_rq, samples, got);
    }
  }
  return 0; /* main deletes the participant: peers see the node's instances with no writers */
}

/* ---- monitor ----------------------------------------------------------------------------------- */

static int run_monitor (dds_entity_t dp, double seconds)
{
  dds_entity_t rd = endpoint (dp, "ParameterEvents", &paramdds_ParameterEvent_desc, false, qos_state ());
  dds_time_t end = dds_time () + (dds_duration_t) (seconds * 1e9);
  dds_time_t last = 0;
  while (dds_time () < end && (last == 0 || dds_time () - last < DDS_MSECS (500)))
  {
    void *samples[64] = {NULL};
    dds_sample_info_t infos[64];
    dds_return_t got = dds_take (rd, samples, infos, 64, 64);
    if (got <= 0)
    {
      dds_sleepfor (DDS_MSECS (20));
      continue;
    }
    last = dds_time ();
    for (int i = 0; i < got; i++)
    {
      const paramdds_ParameterEvent *ev = samples[i];
      if (!infos[i].valid_data)
        continue;
      if (ev->kind == 1)
        printf ("NODE %s %s %d %lld %u %016llx\n", ev->node_id, ev->host, ev->pid, (long long) ev->revision,
                ev->parameter_count, (unsigned long long) ev->incarnation);
      else
      {
        printf ("PARAM %s %s ", ev->node_id, ev->name);
        print_value (&ev->value);
        putchar ('\n');
        if (ev->who[0] || ev->via[0])
          printf ("BLAME %s %s %s %s %lld %s\n", ev->node_id, ev->name, ev->via[0] ? ev->via : "-",
                  ev->verified ? "verified" : "claimed", (long long) ev->revision, ev->who);
      }
    }
    dds_return_loan (rd, samples, got);
  }
  fflush (stdout);
  return last == 0 ? 3 : 0;
}

/* ---- client ------------------------------------------------------------------------------------ */

static uint64_t client_id (void)
{
  uint64_t id = 0;
  FILE *f = fopen ("/dev/urandom", "rb");
  if (f == NULL || fread (&id, sizeof (id), 1, f) != 1)
    id = ((uint64_t) getpid () << 32) ^ (uint64_t) dds_time ();
  if (f)
    fclose (f);
  return id;
}

/* Wait until the request writer and the reply reader have matched a peer (a VOLATILE request
   written before that is lost), write, and wait for the reply carrying our ids; resend each second
   (the server answers a repeated (client_id, request_id) from its cache). */
static int no_answer_status = 3; /* 5 for a set: once written, a request without an answer may apply */
static dds_time_t call_start;

static void *call (dds_entity_t wr, dds_entity_t rd, const void *request, const char *node, uint64_t cid,
                   uint64_t rid, dds_sample_info_t *info, void **loan)
{
  dds_time_t deadline = call_start + ANSWER_TIMEOUT;
  dds_publication_matched_status_t pm;
  dds_subscription_matched_status_t sm;
  do
  {
    dds_get_publication_matched_status (wr, &pm);
    dds_get_subscription_matched_status (rd, &sm);
    if (pm.current_count > 0 && sm.current_count > 0)
      break;
    dds_sleepfor (DDS_MSECS (10));
  } while (dds_time () < deadline);
  dds_time_t resend = 0;
  while (dds_time () < deadline)
  {
    if (dds_time () >= resend)
    {
      check (dds_write (wr, request), "write request");
      resend = dds_time () + DDS_SECS (1);
    }
    loan[0] = NULL;
    while (dds_take (rd, loan, info, 1, 1) > 0)
    {
      /* every reply type starts with node_id, client_id, request_id */
      const paramdds_GetParametersResponse *head = loan[0];
      if (info->valid_data && strcmp (head->node_id, node) == 0 && head->client_id == cid && head->request_id == rid)
        return loan[0];
      dds_return_loan (rd, loan, 1); /* another client's reply: not ours */
      loan[0] = NULL;
    }
    dds_sleepfor (DDS_MSECS (5));
  }
  fprintf (stderr, "paramdds_peer: no answer from node '%s' within 5 s%s\n", node,
           no_answer_status == 5 ? ": outcome unknown" : "");
  exit (no_answer_status);
}

static int run_client (dds_entity_t dp, const char *verb, const char *node, int argc, char **argv)
{
  uint64_t cid = client_id (), rid = 1;
  dds_sample_info_t info;
  void *loan[1] = {NULL};
  int status = 0;
  call_start = dds_time ();
  if (strcmp (verb, "get") == 0)
  {
    dds_entity_t wr = endpoint (dp, "GetParametersRequest", &paramdds_GetParametersRequest_desc, true, qos_call_writer ());
    dds_entity_t rd = endpoint (dp, "GetParametersResponse", &paramdds_GetParametersResponse_desc, false, qos_call_reader ());
    paramdds_GetParametersRequest rq;
    memset (&rq, 0, sizeof (rq));
    snprintf (rq.node_id, sizeof (rq.node_id), "%s", node);
    rq.client_id = cid, rq.request_id = rid;
    rq.names._length = rq.names._maximum = (uint32_t) argc;
    rq.names._buffer = argv;
    const paramdds_GetParametersResponse *rp = call (wr, rd, &rq, node, cid, rid, &info, loan);
    for (uint32_t i = 0; i < rp->results._length; i++)
    {
      const paramdds_GetParameterResult *r = &rp->results._buffer[i];
      if (r->code[0])
      {
        printf ("MISSING %s %s\n", r->name, r->code);
        status = 1;
        continue;
      }
      printf ("VALUE %s ", r->name);
      print_value (&r->value);
      putchar ('\n');
    }
    dds_return_loan (rd, loan, 1);
  }
  else if (strcmp (verb, "set") == 0)
  {
    dds_entity_t wr = endpoint (dp, "SetParametersRequest", &paramdds_SetParametersRequest_desc, true, qos_call_writer ());
    dds_entity_t rd = endpoint (dp, "SetParametersResponse", &paramdds_SetParametersResponse_desc, false, qos_call_reader ());
    paramdds_SetParametersRequest rq;
    paramdds_Parameter params[64];
    memset (&rq, 0, sizeof (rq));
    memset (params, 0, sizeof (params));
    snprintf (rq.node_id, sizeof (rq.node_id), "%s", node);
    rq.client_id = cid, rq.request_id = rid;
    rq.expected_revision = -1;
    rq.deadline = call_start + ANSWER_TIMEOUT - REPLY_ALLOWANCE;
    char who[256];
    local_identity (who, sizeof (who));
    rq.who = who; /* a claim: a node records it unverified */
    rq.via = "api";
    no_answer_status = 5;
    for (int i = 0; i < argc && i < 64; i++)
    {
      char *eq = strchr (argv[i], '=');
      if (eq == NULL)
      {
        fprintf (stderr, "paramdds_peer: expected NAME=VALUE, got '%s'\n", argv[i]);
        return 2;
      }
      *eq = '\0';
      params[i].name = argv[i];
      parse_value (eq + 1, &params[i].value);
    }
    rq.parameters._length = rq.parameters._maximum = (uint32_t) (argc < 64 ? argc : 64);
    rq.parameters._buffer = params;
    const paramdds_SetParametersResponse *rp = call (wr, rd, &rq, node, cid, rid, &info, loan);
    if (rp->code[0])
    {
      printf ("REFUSED %s %s\n", rp->code, rp->reason);
      status = 1;
    }
    for (uint32_t i = 0; i < rp->results._length; i++)
    {
      const paramdds_SetParameterResult *r = &rp->results._buffer[i];
      if (r->successful)
        printf ("RESULT %s OK\n", r->name);
      else
      {
        printf ("RESULT %s FAILED %s %s\n", r->name, r->code, r->reason);
        status = 1;
      }
    }
    dds_return_loan (rd, loan, 1);
  }
  else
  {
    dds_entity_t wr = endpoint (dp, "ListParametersRequest", &paramdds_ListParametersRequest_desc, true, qos_call_writer ());
    dds_entity_t rd = endpoint (dp, "ListParametersResponse", &paramdds_ListParametersResponse_desc, false, qos_call_reader ());
    paramdds_ListParametersRequest rq;
    memset (&rq, 0, sizeof (rq));
    snprintf (rq.node_id, sizeof (rq.node_id), "%s", node);
    rq.client_id = cid, rq.request_id = rid;
    const paramdds_ListParametersResponse *rp = call (wr, rd, &rq, node, cid, rid, &info, loan);
    for (uint32_t i = 0; i < rp->names._length; i++)
      printf ("NAME %s\n", rp->names._buffer[i]);
    dds_return_loan (rd, loan, 1);
  }
  fflush (stdout);
  return status;
}

int main (int argc, char **argv)
{
  if (argc < 2 || (strcmp (argv[1], "node") == 0 && argc != 3)
      || ((strcmp (argv[1], "get") == 0 || strcmp (argv[1], "set") == 0) && argc < 4)
      || (strcmp (argv[1], "list") == 0 && argc != 3))
  {
    fprintf (stderr, "usage: paramdds_peer node NODE_ID | monitor [SECONDS] | get NODE NAME... | "
                     "set NODE NAME=VALUE... | list NODE\n");
    return 2;
  }
  const char *domain = getenv ("PARAMDDS_DOMAIN");
  dds_entity_t dp = check (dds_create_participant (domain ? (dds_domainid_t) atoi (domain) : 1, NULL, NULL),
                           "participant");
  int status;
  if (strcmp (argv[1], "node") == 0)
    status = run_node (dp, argv[2]);
  else if (strcmp (argv[1], "monitor") == 0)
    status = run_monitor (dp, argc > 2 ? atof (argv[2]) : 5.0);
  else if (strcmp (argv[1], "get") == 0 || strcmp (argv[1], "set") == 0 || strcmp (argv[1], "list") == 0)
    status = run_client (dp, argv[1], argv[2], argc - 3, argv + 3);
  else
  {
    fprintf (stderr, "paramdds_peer: unknown command '%s'\n", argv[1]);
    status = 2;
  }
  dds_delete (dp);
  return status;
}
