#!/usr/bin/env bash
# The school's DDS Security material, made with OpenSSL: one certificate authority, one identity
# (certificate, key, signed permissions) per cab, per cab's sim worker and per server, the signed
# governance document, and a certificate revocation list. Cyclone DDS's own plugins read them
# (protocol/README.md, "Security").
#
#   forklift-pki.sh init DIR [--school NAME] [--days N]   new CA, governance, empty CRL
#   forklift-pki.sh add-cab DIR CAB                        identities cab.CAB and worker.CAB
#   forklift-pki.sh issue DIR KIND ID                      one identity: KIND is cab, worker, server or host
#   forklift-pki.sh revoke DIR NAME                        revoke identity NAME (e.g. cab.cab3)
#   forklift-pki.sh list DIR                               identities and their state
#
# A cab may write only its own controls and read only its own state, frames and session status;
# its worker reads those controls and writes that state and those frames, plus the session's
# events, score and status, and reads the instructor's actions for its cab; the server reads
# everything and writes session status, the instructor's actions and requests to worker hosts; a worker host (forklift-host) writes its own status and reports. Permissions
# are per identity, so a cab holding another cab's identity is that other cab: keep keys on the
# cab's disk only. DIR/private/ holds the CA key: on a real school network keep it offline.
set -euo pipefail

die() { echo "forklift-pki: $*" >&2; exit 2; }
usage() { sed -n '6,11p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

# Domain ids the documents cover (all a school uses; the tests use many).
DOMAIN_MIN=0
DOMAIN_MAX=230  # Cyclone refuses a governance document naming a higher id

valid_id() { [[ "$1" =~ ^[A-Za-z0-9_-]{1,32}$ ]] || die "'$1' is not an id (1-32 letters, digits, - or _)"; }

school_of() { cat "$1/school"; }

# An ISO time for the permissions' validity, from openssl's certificate dates.
cert_time() { date -u -d "$(openssl x509 -in "$1" -noout "-$2" | cut -d= -f2)" +%Y-%m-%dT%H:%M:%S; }

sign_smime() {  # DIR IN OUT: S/MIME signed by the CA, as DDS Security wants for both documents
  openssl smime -sign -in "$2" -text -out "$3" -signer "$1/ca.pem" -inkey "$1/private/ca.key" 2>/dev/null \
    || die "cannot sign $2"
}

cmd_init() {
  local dir="" school="Forklift School" days=3650
  while [ $# -gt 0 ]; do
    case "$1" in
      --school) school="$2"; shift 2 ;;
      --days) days="$2"; shift 2 ;;
      -*) usage ;;
      *) dir="$1"; shift ;;
    esac
  done
  [ -n "$dir" ] || usage
  [ ! -e "$dir/ca.pem" ] || die "$dir already has a CA"
  # The school's name goes into every subject; keep it to characters DNs carry without escaping.
  [[ "$school" =~ ^[A-Za-z0-9\ ._-]{1,64}$ ]] || die "--school: letters, digits, space, . _ - only"
  mkdir -p "$dir/private" "$dir/identities" "$dir/issued"
  chmod 700 "$dir/private"
  echo "$school" > "$dir/school"
  openssl ecparam -name prime256v1 -genkey -noout -out "$dir/private/ca.key"
  openssl req -x509 -new -key "$dir/private/ca.key" -sha256 -days "$days" -subj "/O=$school/CN=$school CA" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign,digitalSignature" -out "$dir/ca.pem"
  : > "$dir/index.txt"
  echo 1000 > "$dir/serial"
  echo 1000 > "$dir/crlnumber"
  write_ca_config "$dir"
  write_governance "$dir/governance.xml"
  sign_smime "$dir" "$dir/governance.xml" "$dir/governance.p7s"
  make_crl "$dir"
  echo "forklift-pki: CA for '$school' in $dir"
}

write_ca_config() {  # the minimal `openssl ca` database, for issuing and revoking
  cat > "$1/openssl.cnf" <<EOF
[ ca ]
default_ca = school
[ school ]
dir = $1
database = \$dir/index.txt
serial = \$dir/serial
crlnumber = \$dir/crlnumber
new_certs_dir = \$dir/issued
certificate = \$dir/ca.pem
private_key = \$dir/private/ca.key
default_md = sha256
default_crl_days = 3650
policy = anything
unique_subject = no
copy_extensions = none
[ anything ]
organizationName = supplied
commonName = supplied
[ identity ]
basicConstraints = critical,CA:FALSE
keyUsage = critical,digitalSignature,keyAgreement
EOF
}

# Everything encrypted and access-controlled: discovery (so topic and partition names stay
# private), liveliness, and every topic's samples (submessage and payload).
write_governance() {
  cat > "$1" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>$DOMAIN_MIN</min><max>$DOMAIN_MAX</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>fk_*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
}

make_crl() {
  openssl ca -config "$1/openssl.cnf" -gencrl -out "$1/crl.pem" 2>/dev/null || die "cannot write the CRL"
}

rule() {  # publish|subscribe PARTITION TOPIC...: one rule; no partition means the default one
  local kind="$1" partition="$2"; shift 2
  echo "        <$kind>"
  echo "          <topics>"
  for t in "$@"; do echo "            <topic>$t</topic>"; done
  echo "          </topics>"
  [ -z "$partition" ] || echo "          <partitions><partition>$partition</partition></partitions>"
  echo "        </$kind>"
}

rules_for() {  # KIND ID
  local p="cab.$2"
  case "$1" in
    cab)
      rule publish "$p" fk_Controls fk_CabAnnounce
      rule subscribe "$p" fk_TruckState fk_SceneMotion fk_Frame fk_SessionStatus fk_Event ;;
    worker)
      rule subscribe "$p" fk_Controls
      rule publish "$p" fk_TruckState fk_SceneMotion fk_Frame fk_SessionStatus fk_Event
      rule publish "worker.$2" fk_Event fk_Score fk_SessionStatus
      rule subscribe "instructor.$2" fk_InstructorAction ;;
    host)
      rule publish "host.$2" fk_HostStatus fk_WorkerReport
      rule subscribe "host.$2" fk_WorkerRequest ;;
    server)
      rule subscribe "cab.*" fk_TruckState fk_Frame fk_CabAnnounce
      rule publish "cab.*" fk_SessionStatus
      rule subscribe "worker.*" fk_Event fk_Score fk_SessionStatus
      rule subscribe "host.*" fk_HostStatus fk_WorkerReport
      rule publish "host.*" fk_WorkerRequest
      rule publish "instructor.*" fk_InstructorAction
      rule publish "" fk_SessionStatus ;;
  esac
}

cmd_issue() {
  [ $# -eq 3 ] || usage
  local dir="$1" kind="$2" id="$3"
  [ -f "$dir/ca.pem" ] || die "$dir has no CA: run init first"
  case "$kind" in cab|worker|server|host) ;; *) die "KIND must be cab, worker, server or host" ;; esac
  valid_id "$id"
  local name="$kind.$id"
  local out="$dir/identities/$name" school
  school=$(school_of "$dir")
  [ ! -e "$out/cert.pem" ] || die "identity $name exists (revoke it, then remove $out, to re-issue)"
  mkdir -p "$out"
  openssl ecparam -name prime256v1 -genkey -noout -out "$out/key.pem"
  chmod 600 "$out/key.pem"
  openssl req -new -key "$out/key.pem" -subj "/O=$school/CN=$name" -out "$out/request.csr"
  openssl ca -batch -config "$dir/openssl.cnf" -extensions identity -days 3650 -notext \
    -in "$out/request.csr" -out "$out/cert.pem" 2>/dev/null || die "cannot issue $name"
  rm -f "$out/request.csr"
  local from to
  from=$(cert_time "$out/cert.pem" startdate)
  to=$(cert_time "$out/cert.pem" enddate)
  {
    cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$name">
      <subject_name>CN=$name,O=$school</subject_name>
      <validity><not_before>$from</not_before><not_after>$to</not_after></validity>
      <allow_rule>
        <domains><id_range><min>$DOMAIN_MIN</min><max>$DOMAIN_MAX</max></id_range></domains>
EOF
    rules_for "$kind" "$id"
    cat <<EOF
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  } > "$out/permissions.xml"
  sign_smime "$dir" "$out/permissions.xml" "$out/permissions.p7s"
  echo "forklift-pki: issued $name in $out"
}

cmd_revoke() {
  [ $# -eq 2 ] || usage
  local dir="$1" name="$2"
  local cert="$dir/identities/$name/cert.pem"
  [ -f "$cert" ] || die "no identity $name in $dir"
  openssl ca -config "$dir/openssl.cnf" -revoke "$cert" 2>/dev/null || die "cannot revoke $name (already revoked?)"
  make_crl "$dir"
  touch "$dir/identities/$name/REVOKED"
  echo "forklift-pki: revoked $name; participants started from now on refuse it"
}

cmd_list() {
  [ $# -eq 1 ] || usage
  local dir="$1"
  for d in "$dir"/identities/*/; do
    [ -f "$d/cert.pem" ] || continue
    local n; n=$(basename "$d")
    if [ -e "$d/REVOKED" ]; then echo "$n revoked"; else echo "$n valid until $(cert_time "$d/cert.pem" enddate)"; fi
  done
}

[ $# -ge 1 ] || usage
cmd="$1"; shift
case "$cmd" in
  init) cmd_init "$@" ;;
  add-cab) [ $# -eq 2 ] || usage; cmd_issue "$1" cab "$2"; cmd_issue "$1" worker "$2" ;;
  issue) cmd_issue "$@" ;;
  revoke) cmd_revoke "$@" ;;
  list) cmd_list "$@" ;;
  *) usage ;;
esac
