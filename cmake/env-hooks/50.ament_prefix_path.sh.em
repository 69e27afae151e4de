# Debian's pluginlib finds nodelet plugins through the ament index: this prefix holds
# wet_curly_hair's (share/ament_index/resource_index/nodelet__pluginlib__plugin/wet_curly_hair).
@[if DEVELSPACE]@
_wch_prefix="@(CATKIN_DEVEL_PREFIX)"
@[else]@
_wch_prefix="$CATKIN_ENV_HOOK_WORKSPACE"
@[end if]@
case ":${AMENT_PREFIX_PATH:-}:" in
  *":$_wch_prefix:"*) ;;
  *) export AMENT_PREFIX_PATH="$_wch_prefix${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;;
esac
unset _wch_prefix
