#!/usr/bin/env bash
# Makes the DDS Security files of an esfleet fleet (docs/security.md):
#   OUT_DIR/ca/              identity CA and permissions CA (keys: keep them off the robots)
#   OUT_DIR/governance.xml   the fleet's governance (signed copy in every identity directory)
#   OUT_DIR/<id>/            one directory per identity, to copy to that robot and pass as
#                            --secure: identity_ca.pem cert.pem key.pem permissions_ca.pem
#                            governance.p7s permissions.p7s (+ permissions.xml, readable)
#
# Usage: make-fleet-certs.sh [--days N] [--role ID=ROLE]... [--revoke ID]... OUT_DIR ID...
# Roles follow from the id: leader -> leader, sim -> simulator, monitor and view -> read-all
# (esfleet-fleet's monitor, esfleet-view: they subscribe to every topic and may publish none),
# anything else -> follower (robot); --role ID=leader|sim|monitor|view|follower|contributor
# overrides that for one id. A contributor is a follower that may also send its scans to the
# leader's map (esfleet-follower --contribute, docs/contribute.md); a plain follower may not.
# Ids: letters, digits, '-', '_', '.' (they become partition names).
# Rerunning with an existing OUT_DIR reuses its CAs (adding a robot = rerun with its id; the other
# robots' files stay valid). --revoke ID adds ID's certificate to the identity CA's CRL and
# writes OUT_DIR/<every id>/crl.pem (docs/security.md: how revocation works and what it costs).
set -euo pipefail

days=3650
revoke=()
declare -A role=()
while [[ $# -gt 0 && $1 == --* ]]; do
  case $1 in
    --days) days=$2; shift 2 ;;
    --revoke) revoke+=("$2"); shift 2 ;;
    --role) role[${2%%=*}]=${2#*=}; shift 2 ;;
    --help | -h) sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "make-fleet-certs.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
if [[ $# -lt 1 || ( $# -lt 2 && ${#revoke[@]} -eq 0 ) ]]; then
  echo "usage: make-fleet-certs.sh [--days N] [--role ID=ROLE]... [--revoke ID]... OUT_DIR ID..." >&2
  exit 2
fi
out=$1
shift
ids=("$@")
command -v openssl >/dev/null || { echo "make-fleet-certs.sh: openssl not found" >&2; exit 2; }
for id in "${ids[@]}" "${revoke[@]}"; do
  if [[ ! $id =~ ^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$ || $id == ca ]]; then
    echo "make-fleet-certs.sh: bad id '$id' (letters, digits, . _ -; not 'ca')" >&2
    exit 2
  fi
done

for id in "${!role[@]}"; do
  case ${role[$id]} in leader | sim | monitor | view | follower | contributor) ;;
    *) echo "make-fleet-certs.sh: --role $id=${role[$id]}: leader, sim, monitor, view, follower or contributor" >&2
       exit 2 ;;
  esac
done

mkdir -p "$out/ca"
out=$(cd "$out" && pwd)
ca=$out/ca
umask 077

# --- The two CAs (prime256v1), made once -----------------------------------------------------
# Separate identity and permissions CAs: permissions can be re-issued (or a robot cut off by a
# new permissions CA) without touching the identities.
make_ca() {  # name CN
  if [[ ! -f $ca/$1.key.pem ]]; then
    openssl ecparam -name prime256v1 -genkey -noout -out "$ca/$1.key.pem"
    openssl req -new -x509 -sha256 -days "$days" -key "$ca/$1.key.pem" \
      -subj "/C=XX/O=esfleet/CN=$2" \
      -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign,digitalSignature" \
      -out "$ca/$1.pem"
    echo "made $ca/$1.pem"
  fi
}
make_ca identity_ca "esfleet identity CA"
make_ca permissions_ca "esfleet permissions CA"

# --- Governance: the same for every participant ----------------------------------------------
# Discovery and liveliness encrypted; every esfleet topic: read and write access control,
# submessages signed (GMAC), payload encrypted (AES-GCM); unauthenticated participants refused.
cat >"$out/governance.xml" <<'XML'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>SIGN</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
XML

smime_sign() {  # in out
  openssl smime -sign -text -in "$1" -out "$2" -signer "$ca/permissions_ca.pem" \
    -inkey "$ca/permissions_ca.key.pem"
}

# --- Permissions per role ------------------------------------------------------------------
# <criteria topic partitions>: one publish or subscribe element. The map topics live in the
# default partition (the rule's "*" also matches it); robot topics in the robot id's partition.
criteria() {  # kind partition topic...
  local kind=$1 part=$2
  shift 2
  echo "        <$kind>"
  echo "          <topics>"
  for t in "$@"; do echo "            <topic>$t</topic>"; done
  echo "          </topics>"
  echo "          <partitions><partition>$part</partition></partitions>"
  echo "        </$kind>"
}
role_of() {  # id
  local r=${role[$1]:-}
  if [[ -z $r ]]; then
    case $1 in leader | sim | monitor | view) r=$1 ;; *) r=follower ;; esac
  fi
  echo "$r"
}
rules_for() {  # id
  local id=$1
  case $(role_of "$id") in
    leader)
      criteria publish '*' esfleet/map/tiles esfleet/map/tile_deltas esfleet/map/meta
      criteria publish "$id" esfleet/robots/pose esfleet/robots/scan
      criteria subscribe '*' esfleet/robots/scan esfleet/robots/pose esfleet/map/meta \
        esfleet/robots/contribution
      criteria publish '*' esfleet/robots/contribution_status
      ;;
    sim)
      criteria publish 'sim' esfleet/sim/truth
      local k
      for k in "${robots[@]}"; do criteria publish "$k" esfleet/robots/scan; done
      ;;
    monitor | view)  # read everything, publish nothing
      criteria subscribe '*' 'esfleet/*'
      ;;
    follower | contributor)
      criteria subscribe '*' esfleet/map/tiles esfleet/map/tile_deltas esfleet/map/meta
      criteria publish "$id" esfleet/robots/pose esfleet/robots/scan
      criteria subscribe "$id" esfleet/robots/scan
      if [[ $(role_of "$id") == contributor ]]; then
        criteria publish "$id" esfleet/robots/contribution
        criteria subscribe '*' esfleet/robots/contribution_status
      fi
      ;;
    *) echo "make-fleet-certs.sh: unknown role '$(role_of "$id")' of $id" >&2; exit 2 ;;
  esac
}

# The robots the simulator may publish scans for: every follower id in OUT_DIR (old and new).
robots=()
for d in "$out"/*/ "${ids[@]/#/$out/}"; do
  id=$(basename "$d")
  [[ $id == ca ]] && continue
  case $(role_of "$id") in follower | contributor) ;; *) continue ;; esac
  [[ -d $d || " ${ids[*]} " == *" $id "* ]] || continue
  [[ " ${robots[*]} " == *" $id "* ]] || robots+=("$id")
done

now=$(date -u -d "-1 day" +%Y-%m-%dT%H:%M:%S)  # a day back: robots' clocks differ
until=$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)
write_permissions() {  # id subject
  cat >"$out/$1/permissions.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="esfleet-$1">
      <subject_name>$2</subject_name>
      <validity><not_before>$now</not_before><not_after>$until</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
$(rules_for "$1")
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
XML
  smime_sign "$out/$1/permissions.xml" "$out/$1/permissions.p7s"
}

# --- Per identity: key, certificate, signed files -------------------------------------------
for id in "${ids[@]}"; do
  dir=$out/$id
  mkdir -p "$dir"
  if [[ ! -f $dir/key.pem ]]; then
    openssl ecparam -name prime256v1 -genkey -noout -out "$dir/key.pem"
    openssl req -new -sha256 -key "$dir/key.pem" -subj "/C=XX/O=esfleet/CN=$id" -out "$dir/cert.csr"
    openssl x509 -req -sha256 -days "$days" -in "$dir/cert.csr" -CA "$ca/identity_ca.pem" \
      -CAkey "$ca/identity_ca.key.pem" -set_serial "0x$(openssl rand -hex 16)" \
      -extfile <(printf 'basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature,keyAgreement\n') \
      -out "$dir/cert.pem" 2>/dev/null
    rm -f "$dir/cert.csr"
  fi
  cp "$ca/identity_ca.pem" "$dir/identity_ca.pem"
  cp "$ca/permissions_ca.pem" "$dir/permissions_ca.pem"
  smime_sign "$out/governance.xml" "$dir/governance.p7s"
  subject=$(openssl x509 -in "$dir/cert.pem" -noout -subject -nameopt RFC2253 | sed 's/^subject=//')
  write_permissions "$id" "$subject"
  chmod 600 "$dir/key.pem"
  chmod 644 "$dir"/*.pem "$dir"/*.p7s "$dir"/*.xml 2>/dev/null || true
  chmod 600 "$dir/key.pem"
  echo "made $dir (subject $subject)"
done
# A new robot id changes what the simulator may publish: re-sign its permissions too.
if [[ -d $out/sim && " ${ids[*]} " != *" sim "* ]]; then
  write_permissions sim "$(openssl x509 -in "$out/sim/cert.pem" -noout -subject -nameopt RFC2253 |
    sed 's/^subject=//')"
  echo "re-signed $out/sim/permissions.p7s (robots: ${robots[*]})"
fi

# --- Revocation: a CRL of the identity CA ------------------------------------------------------
if [[ ${#revoke[@]} -gt 0 ]]; then
  db=$ca/crl-db
  mkdir -p "$db"
  touch "$db/index.txt"
  [[ -f $db/crlnumber ]] || echo 1000 >"$db/crlnumber"
  cat >"$db/openssl.cnf" <<CNF
[ ca ]
default_ca = fleet
[ fleet ]
database = $db/index.txt
crlnumber = $db/crlnumber
default_md = sha256
default_crl_days = $days
CNF
  for id in "${revoke[@]}"; do
    [[ -f $out/$id/cert.pem ]] || { echo "make-fleet-certs.sh: no $out/$id/cert.pem" >&2; exit 2; }
    openssl ca -config "$db/openssl.cnf" -revoke "$out/$id/cert.pem" \
      -keyfile "$ca/identity_ca.key.pem" -cert "$ca/identity_ca.pem" 2>&1 | grep -v '^Using' || true
    echo "revoked $id"
  done
  openssl ca -config "$db/openssl.cnf" -gencrl -keyfile "$ca/identity_ca.key.pem" \
    -cert "$ca/identity_ca.pem" -out "$ca/crl.pem" 2>/dev/null
  for d in "$out"/*/; do
    [[ $(basename "$d") == ca ]] && continue
    cp "$ca/crl.pem" "$d/crl.pem"
  done
  echo "wrote $ca/crl.pem and a copy in every identity directory: redeploy them"
fi
